"""Tables I-VI and Gráficos 1-4 of 003_8b306f4736fa5051.txt from the study's archives."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from pipeline.studies.specs import FigureSpec, TableSpec
from pipeline.studies.common import published

STUDY = "mariano2019"
T = "/mariano2019/"
NOT_MEASURED = "not measured"
TIE = 0.02  # |ratio - 1| below this is called a tie: the spread between configurations is ~1 %
RECOVER = 0.05  # table04_print_variant: ours "recovers" the published ratio when within 5 % of it
UART_BITS = 10  # 8N1 frame: start + 8 data + stop bits per character (the computed rows)
VARIANT_LABEL = {
    "chain_general": "chain, general (eqs. 21-22 model)",
    "chain_folded": "chain, arm constants folded",
    "closed_printed": "closed form eqs. 23-28 as printed",
    "closed_factored": "closed form eqs. 23-28 factored",
    "closed_xyzphi": "closed form eqs. 29-32 from (x, y, z, φ)",
    "from_pose": "eqs. 29-32 from a pose",
}
ALG = {"htm": "HTM", "dq": "DQ", "closed": "closed form (either)"}


def _by_measure(archives) -> dict:
    out = {}
    for a in archives:
        out.setdefault(a.metadata.get("measurement", ""), []).append(a)
    return out


def _msgs(archives, ch) -> list[dict]:
    return [r for a in archives for r in a.messages(T + ch)]


def _q(x, q):
    return float(np.percentile(x, q)) if len(x) else np.nan


def _count_cols(r) -> dict:
    return {"trig (ours)": r["trig"], "add/sub (ours)": r["add"], "mul (ours)": r["mul"], "div (ours)": r["div"],
            "sqrt (ours)": r["sqrt"], "×2^k (ours)": r["scale"], "flop (ours)": r["flop"]}


def _pub_cols(pub, alg) -> dict:
    row = None if pub is None or alg not in set(pub["algebra"]) else pub[pub["algebra"] == alg].iloc[0]
    keys = (("trig (published)", "trig"), ("add/sub (published)", "add_sub"), ("mul (published)", "mul"),
            ("flop (published)", "flop_total"))
    return {k: (np.nan if row is None else row[c]) for k, c in keys}


def _mcu(by) -> dict:
    arch = by.get("mcu", [])
    status = _msgs(arch, "mcu_status")
    st = status[0] if status else {"measured": False, "hint": "no MCU archive", "missing": []}
    return {"status": st, "fk": pd.DataFrame(_msgs(arch, "mcu_fk")), "sizes": pd.DataFrame(_msgs(arch, "mcu_sizes")),
            "ops": pd.DataFrame(_msgs(arch, "mcu_ops")), "print": pd.DataFrame(_msgs(arch, "mcu_print"))}


def _not_measured_note(st) -> str:
    return (f"MCU rows NOT MEASURED: missing {', '.join(st.get('missing', [])) or 'toolchain'}; to enable: "
            f"{st.get('hint', '')}.")


def _table01(mcu: dict, st: dict, published_dir: Path) -> TableSpec:
    """Table I: flop weights against measured cycles relative to an addition."""
    pub1 = published(published_dir, STUDY, "table01_flop_weights")
    weights = {"add": 1, "mul": 1, "div": 4, "sqrt": 4, "sin": 8, "cos": 8, "atan2": 8}
    rows = []
    ops = mcu["ops"]
    base = add = np.nan
    if len(ops):
        base = ops.loc[ops["op"] == "load_store", "cycles"].median()
        add = ops.loc[ops["op"] == "add", "cycles"].median() - base
    for op, w in weights.items():
        cyc = ops.loc[ops["op"] == op, "cycles"] - base if len(ops) else pd.Series(dtype=float)
        rows.append({"operation": op, "weight [flop] (published)": w,
                     "cycles, median (ours)": float(cyc.median()) if len(cyc) else NOT_MEASURED,
                     "cycles relative to add (ours)": float(cyc.median() / add) if len(cyc) else NOT_MEASURED})
    return TableSpec("table01_flop_weights", "Table I / Gráfico 4 — weight of each float operation",
                     pd.DataFrame(rows),
                     "Published: Table I weights. Ours: ATmega328P cycles of one float operation (avr-libc soft float, "
                     "simavr), median over operand pairs, minus the cost of moving the operands; relative to an addition. "
                     + ("" if st["measured"] else _not_measured_note(st))
                     + (f" Published file: {len(pub1)} rows." if pub1 is not None else ""))


def _eq21_22(counts: list) -> TableSpec:
    """Eqs. 21-22: operations of a general m-link chain, counted and by formula."""
    gen = pd.DataFrame(_msgs(counts, "general"))
    rows = []
    for m, g in gen.groupby("m"):
        h, d = g[g["algebra"] == "htm"].iloc[0], g[g["algebra"] == "dq"].iloc[0]
        rows.append({"m": m, "HTM trig (ours)": h["trig"], "HTM trig (eq. 21)": 4 * m,
                     "HTM mul (ours)": h["mul"], "HTM mul (eq. 21)": 70 * m - 64,
                     "HTM add (ours)": h["add"], "HTM add (eq. 21)": 48 * m - 48,
                     "DQ trig (ours)": d["trig"], "DQ trig (eq. 22)": 4 * m,
                     "DQ mul (ours)": d["mul"], "DQ mul (eq. 22)": 60 * m - 48,
                     "DQ add (ours)": d["add"], "DQ add (eq. 22)": 44 * m - 40,
                     "DQ ×½ (ours, not in eq. 22)": d["scale"]})
    return TableSpec("eq21_22_general_chain", "Eqs. 21–22 — operations of a general m-link chain",
                     pd.DataFrame(rows),
                     "Counted by running the chain code on a counting number type (links with run-time DH parameters, "
                     "general 4×4 / DQ products). The DQ link's halvings (θ/2, α/2, a/2, d/2) are listed apart: eq. 22 "
                     "does not count them.")


def _tables02_03(arm: pd.DataFrame, published_dir: Path) -> list[TableSpec]:
    """Tables II and III: FK and IK operations of the 4-DOF arm."""
    out = []
    for kind, name, title, pubname in (("fk", "table02_fk_counts", "Table II — FK operations of the 4-DOF arm",
                                        "table02_fk_flop"),
                                       ("ik", "table03_ik_counts", "Table III — IK operations of the 4-DOF arm",
                                        "table03_ik_flop")):
        pub = published(published_dir, STUDY, pubname)
        rows = []
        for _, r in arm[arm["kind"] == kind].iterrows():
            pub_alg = "htm" if r["algebra"] in ("htm", "closed") else "dq"
            rows.append({"variant": VARIANT_LABEL[r["variant"]], "algebra": ALG[r["algebra"]], **_count_cols(r),
                         "compared with": {"htm": "MTH", "dq": "QDU"}[pub_alg], **_pub_cols(pub, pub_alg)})
        note = ("Ours counted by instrumentation (FK includes the position extraction: free for HTM, eq. 18 for DQ). "
                "flop = Table I weights (×2^k = 1, sign flips 0). The published rows are the authors' hand-simplified "
                "code, which is not published; the closed form is the same for both algebras (the document's own "
                "finding), so it is set beside MTH.")
        out.append(TableSpec(name, title, pd.DataFrame(rows), note))

    return out


def _table04(mcu: dict, st: dict, freq: float, pub4, checks: list) -> TableSpec:
    """Table IV: FK cycles and time on the ATmega328P (the checks its note states appended to ``checks``)."""
    fk = mcu["fk"]
    rows = []
    for alg in ("htm", "dq"):
        p = pub4[pub4["algebra"] == alg].iloc[0] if pub4 is not None else None
        row = {"algebra": ALG[alg]}
        if st["measured"] and len(fk):
            c = fk.loc[fk["variant"] == alg, "total"]
            row.update({"cycles per FK, median (ours)": float(c.median()),
                        "cycles min–max (ours)": f"{int(c.min())}–{int(c.max())}",
                        "time per FK [ms] at 16 MHz (ours)": 1e3 * float(c.median()) / freq})
        else:
            row.update({"cycles per FK, median (ours)": NOT_MEASURED})
        row.update({"counter value (published)": np.nan if p is None else p["counter_value"],
                    "time [s] (published)": np.nan if p is None else p["time_s"]})
        rows.append(row)
    df4 = pd.DataFrame(rows)
    if st["measured"] and len(fk):
        h = fk[fk["variant"] == "htm"].sort_values("i")["total"].to_numpy(float)
        d = fk[fk["variant"] == "dq"].sort_values("i")["total"].to_numpy(float)
        ratio = h / d
        rows.append({"algebra": "ratio HTM/DQ", "cycles per FK, median (ours)": float(np.median(ratio)),
                     "cycles min–max (ours)": f"{ratio.min():.3f}–{ratio.max():.3f}",
                     "counter value (published)": 233176 / 152770})
        df4 = pd.DataFrame(rows)
        err = np.max(np.abs(fk[["x", "y", "z"]].to_numpy() - fk[["x_ref", "y_ref", "z_ref"]].to_numpy()))
        checks.append({"quantity": "max |p_MCU − p_Python| of the timed FK", "value": float(err),
                       "unit": fk["length_unit"].iloc[0]})
        note4 = (f"Ours: generated C (float) on a simulated {st['mcu']} (simavr, {st.get('versions', {}).get('simavr', '')}), "
                 f"{len(h)} joint configurations, Timer1 at the CPU clock, printing outside the timed region; "
                 f"max |p_MCU − p_Python| = {err:.2g} {fk['length_unit'].iloc[0]} (float32 vs float64). The published "
                 "counter (≈ µs) probably includes serial printing: 0.233 s is 3.7 M cycles at 16 MHz.")
    else:
        note4 = _not_measured_note(st)
    return TableSpec("table04_mcu_time", "Table IV — FK time on the ATmega328P", df4, note4)


def _table05(arm: pd.DataFrame, mcu: dict, st: dict, published_dir: Path) -> TableSpec:
    """Table V: cost per function group."""
    pub5 = published(published_dir, STUDY, "table05_ram_model_steps")
    parts = arm[(arm["kind"] == "part") & (arm["variant"] == "chain_general")] if len(arm) else arm
    stage_of = {"transformations": "transformation", "products": "product", "translation": "translation"}
    fk = mcu["fk"]
    fk_col = {"transformations": "links", "products": "products", "translation": "translation"}
    rows = []
    for grp in ("declarations", "transformations", "products", "print_array", "translation", "total"):
        row = {"function group": grp}
        for alg in ("htm", "dq"):
            if grp in stage_of:
                sel = parts[(parts["algebra"] == alg) & (parts["stage"] == stage_of[grp])]
                row[f"{ALG[alg]} operations (ours)"] = int(sel[["trig", "mul", "add", "scale"]].to_numpy().sum())
                if st["measured"] and len(fk):
                    row[f"{ALG[alg]} cycles, median (ours)"] = float(fk.loc[fk["variant"] == alg, fk_col[grp]].median())
            elif grp == "total":
                sel = parts[parts["algebra"] == alg]
                row[f"{ALG[alg]} operations (ours)"] = int(sel[["trig", "mul", "add", "scale"]].to_numpy().sum())
                if st["measured"] and len(fk):
                    row[f"{ALG[alg]} cycles, median (ours)"] = float(fk.loc[fk["variant"] == alg, "total"].median())
            if pub5 is not None:
                p = pub5[pub5["function"] == grp]
                row[f"{ALG[alg]} RAM-model steps (published)"] = p[f"{alg}_steps"].iloc[0] if len(p) else np.nan
        rows.append(row)
    return TableSpec("table05_steps_cycles", "Table V — cost per function group", pd.DataFrame(rows),
                     "RAM-model steps are replaced by measured cycles (what the RAM model approximates) and by the "
                     "instrumented operation counts (trig + mul + add + ×½) of the same general functions. Our "
                     "program has no timed declarations or printing. "
                     + ("" if st["measured"] else _not_measured_note(st)))


def _table06(mcu: dict, st: dict, published_dir: Path) -> TableSpec:
    """Table VI: memory of the FK firmware."""
    pub6 = published(published_dir, STUDY, "table06_memory")
    sizes = mcu["sizes"]
    rows = []
    for alg in ("htm", "dq"):
        p = pub6[pub6["algebra"] == alg].iloc[0] if pub6 is not None else None
        row = {"algebra": ALG[alg]}
        if st["measured"] and len(sizes):
            s = sizes[sizes["variant"] == alg].iloc[0]
            b = sizes[sizes["variant"] == "baseline"].iloc[0]
            row.update({"flash [B] (ours)": int(s["flash"]), "flash of the FK [B] (ours)": int(s["flash"] - b["flash"]),
                        "static SRAM [B] (ours)": int(s["sram"]), "static SRAM of the FK [B] (ours)": int(s["sram"] - b["sram"]),
                        "peak stack [B] (ours)": int(s["stack_peak"]),
                        "peak stack of the FK [B] (ours)": int(s["stack_peak"] - b["stack_peak"])})
        else:
            row["flash [B] (ours)"] = NOT_MEASURED
        row.update({"flash [B] (published)": np.nan if p is None else p["flash_bytes"],
                    "SRAM [B] (published)": np.nan if p is None else p["sram_bytes"]})
        rows.append(row)
    return TableSpec("table06_memory", "Table VI — memory of the FK firmware (ATmega328P: 32 256 B flash for "
                     "sketches, 2 048 B SRAM)", pd.DataFrame(rows),
                     "Ours: avr-size (flash = .text + .data, static SRAM = .data + .bss, as the Arduino IDE reports); "
                     "'of the FK' = minus the same harness without kinematics; peak stack by stack painting. The "
                     "published sketch includes the Arduino core and Serial. "
                     + ("" if st["measured"] else _not_measured_note(st)))


def _host_table(host: pd.DataFrame) -> TableSpec:
    """Host speed of HTM against DQ forward kinematics (not in the document)."""
    rows = []
    if len(host):
        for (robot, impl), g in host.groupby(["robot", "impl"], sort=False):
            h = g[g["algebra"] == "htm"].sort_values("rep")["ns_per_fk"].to_numpy()
            d = g[g["algebra"] == "dq"].sort_values("rep")["ns_per_fk"].to_numpy()
            r = h / d
            rows.append({"robot": robot, "DOF": int(g["dof"].iloc[0]), "implementation": impl,
                         "blocks": len(h), "FKs per block": int(g["fks"].iloc[0]),
                         "HTM median [µs/FK] (ours)": np.median(h) / 1e3, "HTM p5–p95 [µs] (ours)":
                             f"{_q(h, 5) / 1e3:.3g}–{_q(h, 95) / 1e3:.3g}",
                         "DQ median [µs/FK] (ours)": np.median(d) / 1e3, "DQ p5–p95 [µs] (ours)":
                             f"{_q(d, 5) / 1e3:.3g}–{_q(d, 95) / 1e3:.3g}",
                         "ratio HTM/DQ median (ours)": float(np.median(r)),
                         "ratio p5–p95 (ours)": f"{_q(r, 5):.3f}–{_q(r, 95):.3f}",
                         "DQ faster? (ours)": "yes" if np.median(r) > 1 else "no"})
    return TableSpec("host_fk_speed", "Host speed — HTM vs DQ forward kinematics (not in the document)",
                     pd.DataFrame(rows),
                     "Per-FK time of blocks of FKs, HTM and DQ blocks alternating; ratio per adjacent pair. python = "
                     "pure-Python chain code of this study (pose + position); numpy = pipeline.kinematics fk_htm / fk_dq "
                     "one configuration per call (fk_dq also converts base and tool to DQs each call); numpy_batch = "
                     "one call for a batch; numba = compiled loops of the general chain (pose + position).")


def build_tables(study, archives, published_dir: Path) -> list[TableSpec]:
    """Tables I-VI and eqs. 21-22 beside ours, the print variant of Table IV, the MCU checks, the host speed,
    the IK round trip and the verdict, in that order."""
    by = _by_measure(archives)
    counts = by.get("counting", [])
    checks = []  # numbers the MCU notes state, also given as a table (mcu_checks)
    mcu = _mcu(by)
    st = mcu["status"]
    freq = float(st.get("freq_hz", 16e6))
    arm = pd.DataFrame(_msgs(counts, "arm"))
    pub4 = published(published_dir, STUDY, "table04_interrupt_timing")
    fk, sizes = mcu["fk"], mcu["sizes"]
    out = [_table01(mcu, st, published_dir), _eq21_22(counts), *_tables02_03(arm, published_dir),
           _table04(mcu, st, freq, pub4, checks)]
    out.append(_print_variant_table(mcu, pub4, st, freq, checks))
    if checks:
        out.append(TableSpec("mcu_checks", "Checks of the MCU measurements stated in the notes above",
                             pd.DataFrame(checks), "Every number the Table IV notes state about our measurements."))
    host = pd.DataFrame(_msgs(by.get("host_timing", []), "host_timing"))
    out += [_table05(arm, mcu, st, published_dir), _table06(mcu, st, published_dir), _host_table(host)]

    # IK round trip: the generic solve archives of problem set ik_roundtrip (registered analytic_4dof)
    out.append(TableSpec("ik_roundtrip", "IK round trip FK(IK(pose)) = pose (not in the document)",
                         _ik_roundtrip(archives),
                         "Joint vectors uniform within the limits (problem set ik_roundtrip; start = the generating "
                         "joints); their FK poses solved by the registered closed form analytic_4dof (eqs. 30–32, θ1 "
                         "read from the tool's z axis and the pitch from its x axis), one row per elbow branch (setting "
                         "`elbow`). Errors: independent FK of the returned angles against the goal, over the solved "
                         "poses; 'reported unreachable' = no FK-valid solution on that branch (stop reason 7)."))

    out.append(TableSpec("verdict", "Verdict — which algebra wins which measure", _verdict(arm, fk, sizes, host, st, mcu["print"], _pub_ratio(pub4)),
                         "'HTM' / 'DQ' = the cheaper one by that measure; 'tie' when the ratio is within 2 % of 1. Ratios are "
                         "HTM/DQ (> 1: DQ cheaper)."))
    return out


def _paired(df: pd.DataFrame, col: str) -> tuple[np.ndarray, np.ndarray]:
    """``col`` of the HTM and DQ records of the same configurations (sorted by configuration)."""
    h = df[df["variant"] == "htm"].set_index("i")[col]
    d = df[df["variant"] == "dq"].set_index("i")[col]
    common = sorted(set(h.index) & set(d.index))
    return h.loc[common].to_numpy(float), d.loc[common].to_numpy(float)


def simavr_byte_cycles(ubrr: int, u2x: bool, freq: float) -> float:
    """CPU cycles simavr 1.6 waits between a UDR0 write and UDRE0 (sim/avr_uart.c, avr_uart_baud_write):
    baud = F/(UBRR+1)/(8 or 16) and usec_per_byte = 1e6 / (baud / 11), all in integers (11 bits: start,
    8 data, a parity bit counted even when parity is off, 1 stop)."""
    baud = int(freq) // (int(ubrr) + 1) // (8 if u2x else 16)
    return (1_000_000 // (baud // 11)) * freq / 1e6


def _print_rows(fk: pd.DataFrame, ram: pd.DataFrame, uart: pd.DataFrame, freq: float, pub_ratio: float,
                pub_cols: dict) -> list[dict]:
    """The rows of table04_print_variant: FK alone, FK + printing to RAM, FK + printing over simavr's UART
    per baud rate, and per baud rate FK + printing with a computed 8N1 frame."""
    def row(region, source, baud, h, d, hc, dc, per_char):
        r = h / d
        med = float(np.median(r))
        rec = "yes" if np.isfinite(pub_ratio) and abs(med / pub_ratio - 1) <= RECOVER else "no"
        return {"timed region": region, "source": source, "baud set / actual [bit/s]": baud,
                "HTM characters printed, median (ours)": float(np.median(hc)),
                "DQ characters printed, median (ours)": float(np.median(dc)),
                "cycles per character (measured: print cycles / characters; computed: 8N1 byte time)": per_char,
                "HTM cycles, median (ours)": float(np.median(h)), "DQ cycles, median (ours)": float(np.median(d)),
                "HTM time [ms] at 16 MHz (ours)": 1e3 * float(np.median(h)) / freq,
                "DQ time [ms] at 16 MHz (ours)": 1e3 * float(np.median(d)) / freq,
                "ratio HTM/DQ, median (ours)": med, "ratio min–max (ours)": f"{r.min():.3f}–{r.max():.3f}",
                **pub_cols, f"recovers the published ratio (within {RECOVER:.0%})": rec}

    measured = "measured (simavr)"
    h, d = _paired(fk, "total")
    rows = [row("FK only (Table IV, table04_mcu_time)", measured, "—", h, d, np.zeros(len(h)), np.zeros(len(d)), np.nan)]
    if len(ram):
        h, d = _paired(ram, "total")
        hc, dc = _paired(ram, "chars")
        per = float(np.median(ram["print"] / ram["chars"]))
        rows.append(row("FK + print, text to RAM (formatting only, no UART)", measured, "—", h, d, hc, dc, per))
    for baud, g in uart.groupby("baud", sort=True):
        actual = float(g["baud_actual"].iloc[0])
        bset = f"{int(baud)} / {actual:.0f}"
        h, d = _paired(g, "total")
        hc, dc = _paired(g, "chars")
        rows.append(row(f"FK + print at {int(baud)} baud (simavr UART)", measured, bset, h, d, hc, dc,
                        float(np.median(g["print"] / g["chars"]))))
    for baud, g in uart.groupby("baud", sort=True):
        if not len(ram):
            break
        actual = float(g["baud_actual"].iloc[0])
        byte = UART_BITS * freq / actual   # cycles per 8N1 character
        comp = g[["variant", "i", "fk", "chars"]].merge(ram[["variant", "i", "print"]], on=["variant", "i"])
        comp["total"] = comp["fk"] + np.maximum(comp["print"], comp["chars"] * byte)
        h, d = _paired(comp, "total")
        hc, dc = _paired(comp, "chars")
        rows.append(row(f"FK + print at {int(baud)} baud, 8N1 frame (computed)",
                        f"computed: FK and formatting measured, UART = characters × {UART_BITS} bit / baud",
                        f"{int(baud)} / {actual:.0f}", h, d, hc, dc, byte))
    return rows


def _uart_formula_check(ram: pd.DataFrame, uart: pd.DataFrame, freq: float, checks: list) -> list[str]:
    """Per baud rate, how far the computed rows' formula with simavr's own byte time is from the simavr rows
    (one phrase each for the note; the numbers appended to ``checks``)."""
    # the computed rows' formula with simavr's own byte time, against the simavr rows (its accuracy)
    check = []
    if len(ram):
        for baud, g in uart.groupby("baud", sort=True):
            byte = simavr_byte_cycles(g["ubrr"].iloc[0], bool(g["u2x"].iloc[0]), freq)
            m = g[["variant", "i", "fk", "chars", "total"]].merge(ram[["variant", "i", "print"]], on=["variant", "i"])
            est = m["fk"] + np.maximum(m["print"], m["chars"] * byte)
            dev = est / m["total"] - 1
            ratio8n1 = byte / (UART_BITS * freq / float(g["baud_actual"].iloc[0]))
            check.append(f"{int(baud)} baud {dev.min():+.1%} to {dev.max():+.1%} (simavr's byte time {byte:.0f} "
                         f"cycles = {ratio8n1:.3f} × the 8N1 one)")
            checks.extend([{"quantity": f"computed rows' deviation from the simavr rows, smallest, {int(baud)} baud",
                            "value": 100 * float(dev.min()), "unit": "%"},
                           {"quantity": f"computed rows' deviation from the simavr rows, largest, {int(baud)} baud",
                            "value": 100 * float(dev.max()), "unit": "%"},
                           {"quantity": f"simavr's byte time, {int(baud)} baud", "value": float(byte), "unit": "cycles"},
                           {"quantity": f"simavr's byte time / the 8N1 byte time, {int(baud)} baud",
                            "value": float(ratio8n1), "unit": "-"}])
    return check


def _print_variant_table(mcu, pub4, st, freq, checks: list | None = None) -> TableSpec:
    """Table IV with the result printed inside the timed region (print_array of Tabela V).

    Rows: the FK alone (``mcu_fk``), FK + printing to RAM (formatting only), FK + printing over
    simavr's UART at each measured baud rate (``mcu_print``), and per baud rate the same with a
    real 8N1 frame computed as FK + max(formatting, characters x 10 bit / baud) from the measured FK
    cycles, formatting cycles and characters of the same configuration. The numbers its note states
    about the measurements are appended to ``checks`` (rows of the mcu_checks table).
    """
    checks = [] if checks is None else checks
    name, title = "table04_print_variant", "Table IV with printing — FK + print_array of the result in the timed region"
    pr, fk = mcu["print"], mcu["fk"]
    pub = {}
    if pub4 is not None:
        pub = {alg: pub4[pub4["algebra"] == alg].iloc[0] for alg in ("htm", "dq") if alg in set(pub4["algebra"])}
    pub_ratio = _pub_ratio(pub4)
    pub_cols = {"HTM time [ms] (published)": 1e3 * float(pub["htm"]["time_s"]) if "htm" in pub else np.nan,
                "DQ time [ms] (published)": 1e3 * float(pub["dq"]["time_s"]) if "dq" in pub else np.nan,
                "ratio HTM/DQ (published)": pub_ratio}
    if not st["measured"] or not len(pr) or not len(fk):
        why = _not_measured_note(st) if not st["measured"] else (
            "Print variants NOT MEASURED: the MCU archive has no mcu_print records (rerun mariano_measure_mcu).")
        return TableSpec(name, title, pd.DataFrame([{"timed region": NOT_MEASURED, **pub_cols}]), why)

    ram, uart = pr[pr["mode"] == "ram"], pr[pr["mode"] == "uart"]
    df = pd.DataFrame(_print_rows(fk, ram, uart, freq, pub_ratio, pub_cols))
    check = _uart_formula_check(ram, uart, freq, checks)
    n_conf = int(pr["i"].nunique())
    digits = int(pr["digits"].iloc[0])
    err = max(float(np.max(np.abs(np.asarray(v, float) - np.asarray(r, float))))
              for v, r in zip(pr["values"], pr["values_ref"]))
    checks.append({"quantity": "printed values against the Python chain, largest difference", "value": err,
                   "unit": pr["length_unit"].iloc[0]})
    bauds = sorted(int(b) for b in uart["baud"].unique())
    pub_chars = ""
    if len(pub) == 2 and bauds:
        b0 = bauds[0]
        act = float(uart.loc[uart["baud"] == b0, "baud_actual"].iloc[0])
        ch = {alg: float(pub[alg]["time_s"]) * act / UART_BITS for alg in ("htm", "dq")}
        pub_chars = (f" The published times would fill {ch['htm']:.0f} (HTM) and {ch['dq']:.0f} (DQ) characters at "
                     f"{b0} baud 8N1 (computed from the published seconds). The published counters mod 4 are "
                     f"{int(pub['htm']['counter_value']) % 4} and {int(pub['dq']['counter_value']) % 4}: they cannot "
                     "both be differences of Arduino's micros() (4 µs steps at 16 MHz).")
    note = (f"Ours: the FK programs of table04_mcu_time, then, inside the same Timer1 region, the final pose printed "
            f"as a sketch's print_array would (HTM: the 4×4 matrix, one row per line; DQ: the 8 components; each "
            f"float as Arduino's Print::print(float), {digits} decimals, a space after each value, CR LF after each "
            f"line), {n_conf} joint configurations per row; ratio = median over configurations of HTM/DQ of the same "
            f"configuration. The UART is set as Arduino's Serial.begin (U2X, UBRR = (F_CPU/4/baud − 1)/2; 9600 baud "
            f"is Serial.begin's usual rate in sketches of the time) and each character waits for UDRE0 (blocking "
            f"write, UART idle when the region starts; Arduino's interrupt-driven 64-byte TX buffer is not modelled). "
            f"simavr (sim/avr_uart.c) models the byte time: a UDR0 write clears UDRE0 and sets it again "
            f"1e6/(baud/11) µs later (integer µs; 11 bits per byte — a parity bit is counted even when parity is off "
            f"— and no double buffering), so the 'simavr UART' rows charge more per character than a real "
            f"8N1 frame; the 'computed' rows use 10 bits per character instead: measured FK cycles + max(measured "
            f"formatting cycles, characters × 10 × F_CPU / baud); the same formula with simavr's byte time "
            f"instead of 10 bits deviates from the simavr rows by {'; '.join(check) or 'n/a'} (it ignores that the "
            f"first character does not wait and the formatting the transmission does not hide). The "
            f"printed values agree with the Python chain to {err:.2g} {pr['length_unit'].iloc[0]} "
            f"(rounding to {digits} decimals). The document does not say what its sketch printed or whether the "
            f"printing was timed; 'recovers' = our median ratio within {RECOVER:.0%} of the published "
            f"{pub_ratio:.3f}." + pub_chars)
    return TableSpec(name, title, df, note)


def _ik_roundtrip(archives) -> pd.DataFrame:
    """One row per solver label of problem set ik_roundtrip (elbow branch), from its solve records."""
    import json

    rows = []
    sign = {"positive": 1, "negative": -1}
    for a in archives:
        if a.metadata.get("problem_set") != "ik_roundtrip":
            continue
        df = a.frame()
        ok = df[df["success"]]
        d = np.abs(np.angle(np.exp(1j * (np.stack(ok["q_solution"]) - np.stack(ok["q_start"]))))) if len(ok) else None
        elbow = json.loads(a.metadata.get("settings", "{}")).get("elbow", "both")
        rows.append({"elbow branch (sign in eq. 30)": sign.get(elbow, elbow), "poses": len(df),
                     "reported unreachable": int((~df["success"]).sum()),
                     "max |Δp| (ours)": float(ok["position_error"].max()) if len(ok) else np.nan,
                     "max angle [rad] (ours)": float(ok["orientation_error"].max()) if len(ok) else np.nan,
                     "poses whose joints this branch returns": int(np.all(d < 1e-9, axis=1).sum()) if len(ok) else 0,
                     "length_unit": df["length_unit"].iloc[0] if len(df) else ""})
    order = {1: 0, -1: 1}
    return pd.DataFrame(sorted(rows, key=lambda r: order.get(r["elbow branch (sign in eq. 30)"], 2)))


def _pub_ratio(pub4) -> float:
    """Published counter HTM / DQ of Tabela IV (NaN without the published file)."""
    if pub4 is None or not {"htm", "dq"} <= set(pub4["algebra"]):
        return np.nan
    c = pub4.set_index("algebra")["counter_value"]
    return float(c["htm"] / c["dq"])


def _verdict(arm, fk, sizes, host, st, prt=None, pub_print=np.nan) -> pd.DataFrame:
    rows = []

    def add(measure, ours, ratio, published, pub_ratio):
        if isinstance(ratio, float) and np.isfinite(ratio) and abs(ratio - 1.0) < TIE:
            ours = f"tie (within {TIE:.0%})"
        rows.append({"measure": measure, "cheaper (ours)": ours, "ratio HTM/DQ (ours)": ratio,
                     "cheaper (published)": published, "ratio HTM/DQ (published)": pub_ratio})

    if len(arm):
        for variant in ("chain_general", "chain_folded"):
            f = arm[(arm["kind"] == "fk") & (arm["variant"] == variant)].set_index("algebra")["flop"]
            r = f["htm"] / f["dq"]
            add(f"FK flop, {VARIANT_LABEL[variant]}", "HTM" if r < 1 else "DQ", r, "HTM (Table II)", 92 / 169)
        ik = arm[(arm["kind"] == "ik") & (arm["variant"] == "from_pose")].set_index("algebra")["flop"]
        add("IK flop, from a pose", "HTM" if ik["htm"] < ik["dq"] else "DQ", ik["htm"] / ik["dq"], "HTM (Table III)",
            68 / 171)
    if st["measured"] and len(fk):
        h = fk.loc[fk["variant"] == "htm", "total"].median()
        d = fk.loc[fk["variant"] == "dq", "total"].median()
        add("MCU cycles per FK", "HTM" if h < d else "DQ", h / d, "DQ (Table IV)", 233176 / 152770)
        s = sizes.set_index("variant")
        fh, fd = s.loc["htm", "flash"] - s.loc["baseline", "flash"], s.loc["dq", "flash"] - s.loc["baseline", "flash"]
        add("flash of the FK", "HTM" if fh < fd else "DQ", fh / fd, "HTM (Table VI)", 4780 / 7088)
        rh, rd = s.loc["htm", "sram"] - s.loc["baseline", "sram"], s.loc["dq", "sram"] - s.loc["baseline", "sram"]
        add("static SRAM of the FK", "HTM" if rh < rd else "DQ", rh / rd, "DQ (Table VI)", 958 / 496)
        # what the Arduino IDE reports (Table VI's source): the whole firmware, baseline included
        for mem, pub in (("flash", 4780 / 7088), ("sram", 958 / 496)):
            h, d = s.loc["htm", mem], s.loc["dq", mem]
            add(f"{'flash' if mem == 'flash' else 'static SRAM'}, whole firmware (as the Arduino IDE reports)",
                "HTM" if h < d else "DQ", h / d, "HTM (Table VI)" if mem == "flash" else "DQ (Table VI)", pub)
        if prt is not None and len(prt):
            for baud, g in prt[prt["mode"] == "uart"].groupby("baud", sort=True):
                h, d = g.loc[g["variant"] == "htm", "total"].median(), g.loc[g["variant"] == "dq", "total"].median()
                add(f"MCU cycles per FK + print of the pose, {int(baud)} baud (simavr)", "HTM" if h < d else "DQ",
                    h / d, "DQ (Table IV)", pub_print)
    else:
        add("MCU cycles / flash / SRAM", NOT_MEASURED, np.nan, "DQ / HTM / DQ", np.nan)
    if len(host):
        for impl, g in host.groupby("impl", sort=False):
            m = g.groupby("algebra")["ns_per_fk"].median()
            r = m["htm"] / m["dq"]
            add(f"host FK time, {impl} (pooled over robots)", "HTM" if r < 1 else "DQ", r, "—", np.nan)
    return pd.DataFrame(rows)


def _per_part_figures(arm: pd.DataFrame, out_dir: Path) -> list[FigureSpec]:
    """Gráficos 2 and 3: operations of each link transformation and of each product, general and folded code."""
    from pipeline.report.plotting import plt, save

    figs = []
    if len(arm):
        parts = arm[arm["kind"] == "part"]
        for stage, stem, title in (("transformation", "grafico2_per_transformation",
                                    "Gráfico 2 — operations of each link transformation (4-DOF arm)"),
                                   ("product", "grafico3_per_product",
                                    "Gráfico 3 — operations of each product (4-DOF arm)")):
            fig, axes = plt.subplots(1, 2, figsize=(8.5, 3.6), sharey=True)
            for ax, variant in zip(axes, ("chain_general", "chain_folded")):
                sel = parts[(parts["stage"] == stage) & (parts["variant"] == variant)]
                idx = sorted(sel["index"].unique())
                x = np.arange(len(idx))
                w = 0.13
                k = 0
                for alg, hatch in (("htm", ""), ("dq", "//")):
                    for op in ("trig", "mul", "add"):
                        vals = [int(sel[(sel["algebra"] == alg) & (sel["index"] == i)][op].sum()) for i in idx]
                        ax.bar(x + (k - 2.5) * w, vals, w, hatch=hatch, label=f"{ALG[alg]} {op}")
                        k += 1
                ax.set_xticks(x, [f"{'link' if stage == 'transformation' else 'product'} {i}" for i in map(int, idx)])
                ax.set_title(VARIANT_LABEL[variant], fontsize=9)
                ax.grid(axis="y", alpha=0.3)
            axes[0].set_ylabel("operations (counted)")
            axes[1].legend(fontsize=7, ncol=2)
            figs.append(FigureSpec(save(fig, out_dir, stem), title,
                                   "Left: general functions (eqs. 21–22 model); right: the same code with the arm's "
                                   "constants folded (α and zero lengths known at compile time)."))
    return figs


def build_figures(study, archives, out_dir: Path) -> list[FigureSpec]:
    """Gráficos 1-4 of the document from our counts and measurements, and the host speed ratios."""
    from pipeline.report.plotting import plt, save

    by = _by_measure(archives)
    counts = by.get("counting", [])
    figs = []
    gen = pd.DataFrame(_msgs(counts, "general"))
    if len(gen):
        fig, ax = plt.subplots(figsize=(6.4, 3.8))
        for alg, ls in (("htm", "-"), ("dq", "--")):
            g = gen[gen["algebra"] == alg].sort_values("m")
            ax.plot(g["m"], g["mul"], ls, marker="o", label=f"{ALG[alg]} multiplications")
            ax.plot(g["m"], g["add"], ls, marker="s", label=f"{ALG[alg]} additions/subtractions")
        ax.set_xlabel("links m")
        ax.set_ylabel("operations (counted)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        figs.append(FigureSpec(save(fig, out_dir, "grafico1_ops_vs_m"), "Gráfico 1 — operations of a general chain vs m",
                               "Counted by instrumentation; equal to eqs. 21–22 for every m (DQ halvings not included)."))
    figs += _per_part_figures(pd.DataFrame(_msgs(counts, "arm")), out_dir)
    mcu = _mcu(by)
    ops = mcu["ops"]
    if len(ops):
        base = ops.loc[ops["op"] == "load_store", "cycles"].median()
        names = ["add", "mul", "div", "sqrt", "sin", "cos", "atan2"]
        add = ops.loc[ops["op"] == "add", "cycles"].median() - base
        rel = [(ops.loc[ops["op"] == n, "cycles"].median() - base) / add for n in names]
        pub = [1, 1, 4, 4, 8, 8, 8]
        fig, ax = plt.subplots(figsize=(6.4, 3.6))
        x = np.arange(len(names))
        ax.bar(x - 0.2, pub, 0.4, label="Table I weight [flop] (published)")
        ax.bar(x + 0.2, rel, 0.4, label="ATmega328P cycles / add cycles (ours)")
        ax.set_xticks(x, names)
        ax.set_ylabel("cost relative to an addition")
        ax.legend(fontsize=8)
        ax.grid(axis="y", alpha=0.3)
        figs.append(FigureSpec(save(fig, out_dir, "grafico4_op_cost"), "Gráfico 4 — cost of each float operation on the MCU",
                               "Published weights (Table I) beside the measured cycles of avr-libc's soft float on a "
                               "simulated ATmega328P, relative to an addition."))
    host = pd.DataFrame(_msgs(by.get("host_timing", []), "host_timing"))
    if len(host):
        fig, ax = plt.subplots(figsize=(7, 3.8))
        labels, data = [], []
        for (robot, impl), g in host.groupby(["robot", "impl"], sort=False):
            h = g[g["algebra"] == "htm"].sort_values("rep")["ns_per_fk"].to_numpy()
            d = g[g["algebra"] == "dq"].sort_values("rep")["ns_per_fk"].to_numpy()
            labels.append(f"{robot}\n{impl}")
            data.append(h / d)
        ax.boxplot(data, whis=(5, 95), showfliers=False)
        ax.axhline(1.0, color="k", lw=0.8)
        ax.set_xticks(range(1, len(labels) + 1), labels, fontsize=7, rotation=45, ha="right")
        ax.set_ylabel("time ratio HTM / DQ  (> 1: DQ faster)")
        ax.grid(axis="y", alpha=0.3)
        figs.append(FigureSpec(save(fig, out_dir, "host_ratio"), "Host speed — HTM/DQ time ratio",
                               "Ratio of adjacent HTM and DQ timing blocks; box = quartiles, whiskers 5–95 %."))
    return figs
