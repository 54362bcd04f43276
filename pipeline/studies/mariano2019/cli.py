"""Study verbs of ``python -m pipeline`` (also the Snakemake rule names of mariano2019).

mariano_count_ops     operation counts (eqs. 21-22, Tables II-III, Gráficos 1-3)
mariano_time_host     host FK timing, HTM vs DQ, for one robot
mariano_measure_mcu   generated C on the simulated ATmega328P (Tables IV-VI, Gráfico 4; FK + printing)
"""

from __future__ import annotations

STUDY = "mariano2019"
TOPIC = "/mariano2019/"


def scaled(value, scale: str):
    """``{full: x, quick: y}`` -> the value for ``scale``; any other value unchanged."""
    if isinstance(value, dict) and set(value) == {"full", "quick"}:
        return value[scale]
    return value


def _meta(study, robot: str, block: str, scale: str, seed) -> dict:
    import hashlib
    import json

    from pipeline.io.archive import run_metadata

    settings = {k: scaled(v, scale) if not isinstance(v, dict) else {kk: scaled(vv, scale) for kk, vv in v.items()}
                for k, v in study.settings.get(block, {}).items()}
    blob = json.dumps({"block": block, "settings": settings, "scale": scale}, sort_keys=True)
    return run_metadata(study=study.id, robot=robot, solver="-", settings=settings, seed=seed,
                        settings_hash=hashlib.sha256(blob.encode()).hexdigest()[:16], scale=scale, measurement=block,
                        problems="-", problem_file="-", problem_sha256="-")


def _schema(title: str, desc: str) -> dict:
    return {"title": f"ik_pipeline.{title}", "type": "object", "description": desc}


def _load(args):
    from pipeline.errors import UsageError as CLIError
    from pipeline.robots import load_robot
    from pipeline.settings import load_study

    study = load_study(args.study)
    if study.id != STUDY:
        raise CLIError(f"{args.study}: field 'study': these verbs are for {STUDY}, not {study.id!r}")
    return study, load_robot(args.robot)


def cmd_count_ops(args) -> None:
    from pipeline.errors import UsageError as CLIError
    from pipeline.io.archive import ArchiveWriter
    from pipeline.studies.mariano2019.measure import count_records

    study, model = _load(args)
    s = study.settings["counting"]
    try:
        recs = count_records(model, s["max_links"], s["seed"])
    except ValueError as exc:
        raise CLIError(str(exc)) from None
    with ArchiveWriter(args.out, _meta(study, model.name, "counting", args.scale, s["seed"])) as w:
        descs = {"general": "counts of the general m-link chain (eqs. 21-22)",
                 "arm": "counts of the 4-DOF arm's FK/IK variants and of each transformation/product"}
        for ch, rows in recs.items():
            w.add_channel(TOPIC + ch, _schema(f"Mariano.{ch}", descs[ch]))
            for r in rows:
                w.write_message(TOPIC + ch, r)
    print(f"wrote {args.out}: {len(recs['general'])} general, {len(recs['arm'])} arm records")


def cmd_time_host(args) -> None:
    import numpy as np

    from pipeline.io.archive import ArchiveWriter
    from pipeline.studies.mariano2019.timing import time_robot

    study, model = _load(args)
    s = study.settings["host_timing"]
    rng = np.random.default_rng([s["seed"], sum(model.name.encode())])
    rows = time_robot(model.chain, s["impls"], scaled(s["reps"], args.scale), scaled(s["calls"], args.scale),
                      scaled(s["batch"], args.scale), s["warmup"], rng)
    with ArchiveWriter(args.out, _meta(study, model.name, "host_timing", args.scale, s["seed"])) as w:
        w.add_channel(TOPIC + "host_timing", _schema("Mariano.host_timing", "per-block FK time [ns per FK]"))
        for r in rows:
            w.write_message(TOPIC + "host_timing", {**r, "robot": model.name, "dof": model.chain.n})
    print(f"wrote {args.out}: {len(rows)} timing blocks for {model.name}")


def cmd_measure_mcu(args) -> None:
    import tempfile

    import numpy as np

    from pipeline.errors import UsageError as CLIError
    from pipeline.io.archive import ArchiveWriter
    from pipeline.studies.mariano2019.avr import AvrError
    from pipeline.studies.mariano2019.measure import mcu_records

    study, model = _load(args)
    s = study.settings["mcu"]
    rng = np.random.default_rng(s["seed"])
    lim = np.where(np.isfinite(model.limits), model.limits, np.array([-np.pi, np.pi]))
    configs = rng.uniform(lim[:, 0], lim[:, 1], size=(scaled(s["configs"], args.scale), model.chain.n))
    try:
        with tempfile.TemporaryDirectory(prefix="mariano_avr_") as tmp:
            recs = mcu_records(model, configs, s, args.build_dir or tmp)
    except (AvrError, ValueError) as exc:
        raise CLIError(str(exc)) from None
    with ArchiveWriter(args.out, _meta(study, model.name, "mcu", args.scale, s["seed"])) as w:
        for ch in ("status", "sizes", "fk", "ops", "print"):
            w.add_channel(TOPIC + "mcu_" + ch, _schema(f"Mariano.mcu_{ch}", f"ATmega328P measurements: {ch}"))
            for r in recs[ch]:
                w.write_message(TOPIC + "mcu_" + ch, r)
    st = recs["status"][0]
    if st["measured"]:
        print(f"wrote {args.out}: {len(recs['fk'])} FK runs, {len(recs['ops'])} operation timings, "
              f"{len(recs['print'])} FK + print runs")
    else:
        print(f"wrote {args.out}: NOT MEASURED (missing {', '.join(st['missing'])}); to enable: {st['hint']}")


def register_cli(sub) -> None:
    for verb, fn, what in (("mariano_count_ops", cmd_count_ops, "count operations of HTM/DQ kinematics (003)"),
                           ("mariano_time_host", cmd_time_host, "time HTM vs DQ FK on this computer (003)"),
                           ("mariano_measure_mcu", cmd_measure_mcu, "size and simulate the FK on an ATmega328P (003)")):
        p = sub.add_parser(verb, help=what)
        p.add_argument("--study", required=True, help="data/studies/mariano2019.yaml")
        p.add_argument("--robot", required=True, help="data/robots/<name>.yaml")
        p.add_argument("--scale", choices=["full", "quick"], default="full")
        p.add_argument("--out", required=True, help="output .mcap")
        if verb == "mariano_measure_mcu":
            p.add_argument("--build-dir", default="", help="keep the generated C and ELF files here")
        p.set_defaults(func=fn)
