"""The study's measurements as plain records (the CLI writes them to MCAP archives).

* :func:`count_records` — operation counts: general chains m = 1..M (eqs. 21-22), the 4-DOF arm's
  FK and IK variants (Tables II-III), per-transformation / per-product counts (Gráficos 2-3).
  The IK round trip is not here: it is the problem set ``ik_roundtrip``, solved by the registered
  closed form ``analytic_4dof`` (the printed eqs. 29-32 below are counted, not used to solve).
* :func:`mcu_records` — flash/SRAM/stack and cycles of the generated C on the simulated MCU
  (Tables IV-VI, Gráfico 4), or one "not measured" record when the toolchain is absent.
"""

from __future__ import annotations

import numpy as np

from pipeline.studies.mariano2019 import algebra as A
from pipeline.studies.mariano2019 import closed_form as CF
from pipeline.studies.mariano2019 import counting as K


def _rec(kind: str, variant: str, algebra: str, c: K.OpCounts, **extra) -> dict:
    return {"kind": kind, "variant": variant, "algebra": algebra, **c.as_dict(), **extra}


def _counted_q(q):
    return [K.Counted(v) for v in q]


def _counted_p(p: dict) -> dict:
    return {k: K.Counted(v) for k, v in p.items()}


def arm_fk_counts(model, q) -> list[dict]:
    """FK variants of the 4-DOF arm, each including the position extraction."""
    p = CF.arm_params(model)
    out = []
    for general, variant in ((True, "chain_general"), (False, "chain_folded")):
        parts = []
        with K.counting() as c:
            A.htm_translation(A.fk_htm_chain(model.chain, _counted_q(q), general, parts))
        out.append(_rec("fk", variant, "htm", c))
        out += [_rec("part", variant, "htm", pc, stage=st, index=i) for st, i, pc in parts]
        parts = []
        with K.counting() as c:
            Q = A.fk_dq_chain(model.chain, _counted_q(q), general, parts)
            c0 = K.snapshot()
            A.dq_translation(Q)
            tr = K.snapshot() - c0
        out.append(_rec("fk", variant, "dq", c))
        out += [_rec("part", variant, "dq", pc, stage=st, index=i) for st, i, pc in parts]
        out.append(_rec("part", variant, "dq", tr, stage="translation", index=0))
        out.append(_rec("part", variant, "htm", K.OpCounts(), stage="translation", index=0))
    for fn, variant in ((CF.fk_printed, "closed_printed"), (CF.fk_factored, "closed_factored")):
        with K.counting() as c:
            fn(_counted_p(p), _counted_q(q))
        out.append(_rec("fk", variant, "closed", c))
    return out


def arm_ik_counts(model, q) -> list[dict]:
    """IK variants: the core eqs. 29-32 from (x, y, z, phi), and from an HTM / a DQ pose."""
    p = CF.arm_params(model)
    x, y, z, phi, _, _ = CF.fk_factored(p, q)
    T = A.fk_htm_chain(model.chain, list(q))
    Q = A.fk_dq_chain(model.chain, list(q))
    out = []
    with K.counting() as c:
        CF.ik(_counted_p(p), *(K.Counted(v) for v in (x, y, z, phi)))
    out.append(_rec("ik", "closed_xyzphi", "closed", c))
    with K.counting() as c:
        CF.ik_from_htm(_counted_p(p), [[K.Counted(v) for v in row] for row in T])
    out.append(_rec("ik", "from_pose", "htm", c))
    with K.counting() as c:
        CF.ik_from_dq(_counted_p(p), [K.Counted(v) for v in Q])
    out.append(_rec("ik", "from_pose", "dq", c))
    return out


def count_records(model, max_links: int, seed: int) -> dict:
    """Every counting record of the study, by channel name (``general``, ``arm``)."""
    general = []
    for m in range(1, max_links + 1):
        for alg in ("htm", "dq"):
            general.append(_rec("general", "chain_general", alg, A.general_chain_counts(m, alg), m=m))
    rng = np.random.default_rng(seed)
    q = rng.uniform(-1.0, 1.0, 4)  # counts do not depend on the values (tested)
    return {"general": general, "arm": arm_fk_counts(model, q) + arm_ik_counts(model, q)}


def mcu_records(model, configs: np.ndarray, mcu: dict, workdir) -> dict:
    """Build, size and simulate the three firmwares (+ the operation-cost one).

    Returns ``{"status": [...], "fk": [...], "sizes": [...], "ops": [...], "print": [...]}``; when the
    toolchain is missing ``status`` says so and the other lists are empty. ``print`` holds the print
    variants (:func:`print_records`).
    """
    from pathlib import Path

    from pipeline.kinematics import fk_htm
    from pipeline.studies.mariano2019 import avr, codegen

    tc = avr.toolchain()
    status = {"measured": tc["available"], "missing": tc["missing"], "versions": tc["versions"],
              "mcu": mcu["mcu"], "freq_hz": mcu["freq_hz"], "cflags": mcu["cflags"],
              "hint": "" if tc["available"] else avr.ENABLE_HINT}
    out = {"status": [status], "fk": [], "sizes": [], "ops": [], "print": []}
    if not tc["available"]:
        return out
    workdir = Path(workdir)
    ref = fk_htm(model.chain, configs)[:, :3, 3]
    for variant in codegen.VARIANTS:
        src = codegen.generate_fk_program(variant, model.chain, configs)
        elf = avr.compile_c(src, workdir, f"fk_{variant}", mcu["mcu"], mcu["cflags"])
        sizes = avr.section_sizes(elf)
        res = avr.parse_fk_output(avr.simulate(elf, mcu["mcu"], mcu["freq_hz"], mcu["timeout_s"]))
        out["sizes"].append({"variant": variant, **sizes, "stack_peak": res["stack_peak"],
                             "timer_overhead": res["overhead"]})
        if variant == "baseline":
            continue
        for c in res["confs"]:
            i = c["i"]
            out["fk"].append({"variant": variant, **c, "q": [float(v) for v in configs[i]],
                              "x_ref": float(ref[i, 0]), "y_ref": float(ref[i, 1]), "z_ref": float(ref[i, 2]),
                              "length_unit": model.length_unit})
    a_vals, b_vals = mcu["op_values"]["a"], mcu["op_values"]["b"]
    elf = avr.compile_c(codegen.generate_ops_program(a_vals, b_vals), workdir, "ops", mcu["mcu"], mcu["cflags"])
    out["ops"] = avr.parse_ops_output(avr.simulate(elf, mcu["mcu"], mcu["freq_hz"], mcu["timeout_s"]))
    out["print"] = print_records(model, configs, mcu, workdir)
    return out


def print_records(model, configs: np.ndarray, mcu: dict, workdir) -> list[dict]:
    """The print variants: FK + printing its final pose inside the timed region, per baud rate.

    Baud rates: ``mcu["print_bauds"]`` if the settings give it, else ``codegen.PRINT_BAUDS``
    (0 = the text goes to RAM: formatting only). One record per (algebra, baud, configuration):
    cycles of the FK, of the printing and of both (``total``), characters sent, the printed values
    and the same values from the Python chain (``values_ref``, float64). Needs the toolchain.
    """
    from pathlib import Path

    from pipeline.studies.mariano2019 import algebra as A
    from pipeline.studies.mariano2019 import avr, codegen

    workdir = Path(workdir)
    ref = {"htm": [np.ravel(A.fk_htm_chain(model.chain, list(q))).tolist() for q in configs],
           "dq": [list(map(float, A.fk_dq_chain(model.chain, list(q)))) for q in configs]}
    out = []
    for baud in mcu.get("print_bauds", codegen.PRINT_BAUDS):
        u = codegen.uart_setting(int(baud), mcu["freq_hz"])
        for variant in codegen.PRINT_VARIANTS:
            alg = variant.removesuffix("_print")
            src = codegen.generate_print_program(variant, model.chain, configs, int(baud), mcu["freq_hz"])
            elf = avr.compile_c(src, workdir, f"{variant}_{int(baud)}", mcu["mcu"], mcu["cflags"])
            res = avr.parse_print_output(avr.simulate(elf, mcu["mcu"], mcu["freq_hz"], mcu["timeout_s"]))
            for c in res["confs"]:
                i = c["i"]
                out.append({"variant": alg, "mode": "ram" if u["baud"] == codegen.PRINT_BUFFERED else "uart",
                            **u, "freq_hz": mcu["freq_hz"], "digits": codegen.PRINT_DIGITS,
                            "timer_overhead": res["overhead"], **c, "n_values": len(c["values"]),
                            "values_ref": ref[alg][i], "q": [float(v) for v in configs[i]],
                            "length_unit": model.length_unit})
    return out
