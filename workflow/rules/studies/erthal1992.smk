# Study erthal1992 (001_7601717b50b5e768.txt) beyond the generic solve jobs (Tests 1, 2, 3, 5, 6, the
# SCARA paths and the analytic PUMA are problem sets solved by the registered solvers): the catalogue
# conversions and the RES files of the path tasks, written from their solve archives (no solving).
# Problem sets listed in study_settings/full_only_problem_sets run only at scale=full.
if "erthal1992" in STUDIES:
    _ER = STUDIES["erthal1992"]
    _ER_SET = _ER.settings
    _ER_RUNS = f"{RESULTS}/erthal1992/runs"
    _ER_PATHS = f"{RESULTS}/erthal1992/paths"
    _ER_FILE = f"{DATA}/studies/erthal1992.yaml"
    _ER_FULL_ONLY = set(_ER_SET.get("full_only_problem_sets", []))

    def _er_kept(pset):
        return SCALE == "full" or pset not in _ER_FULL_ONLY

    STUDY_ARCHIVES["erthal1992"] = (
        [f"{_ER_RUNS}/{p}/{r}__{s}.mcap" for p, r, s in _ER.jobs() if _er_kept(p)]
        + [f"{_ER_RUNS}/catalogue.mcap"]
        + [f"{_ER_PATHS}/{p}__{r}.mcap" for p in _ER_SET["paths"] if _er_kept(p) for r in _ER.set_robots(p)]
    )

    wildcard_constraints:
        er_path="|".join(_ER_SET["paths"]),

    rule erthal_catalogue:
        input:
            robots=[f"{DATA}/robots/{r}.yaml" for r in _ER_SET["zero_positions"]],
            joint_points=[f"{DATA}/erthal1992/{f}" for f in _ER_SET.get("joint_point_inputs", [])],
        output:
            archive=f"{_ER_RUNS}/catalogue.mcap",
            reports=directory(f"{RESULTS}/erthal1992/robots"),
        params:
            settings=_ER_FILE,
            block={k: _ER_SET.get(k) for k in ("zero_positions", "joint_point_inputs", "jog", "roundtrip_seed", "roundtrip_samples", "workspace")},
        log:
            f"{RESULTS}/erthal1992/logs/erthal_catalogue.log",
        threads: 1
        resources:
            mem_mb=RES["solve"]["mem_mb"],
            runtime=RES["solve"]["runtime"],
        shell:
            "python -m pipeline erthal_catalogue --study {params.settings} --data {DATA}"
            " --out {output.archive} --report-dir {output.reports} > {log} 2>&1"

    rule erthal_path_rows:
        input:
            archive=lambda w: f"{_ER_RUNS}/{w.er_path}/{w.robot}__{_ER_SET['paths'][w.er_path]['solver']}.mcap",
            task=lambda w: f"{DATA}/erthal1992/{_ER.problem_sets[w.er_path]['params']['task']}",
            robot=f"{DATA}/robots/{{robot}}.yaml",
        output:
            rows=f"{_ER_PATHS}/{{er_path}}__{{robot}}.mcap",
            res=f"{_ER_PATHS}/{{er_path}}__{{robot}}.RES",
        params:
            settings=_ER_FILE,
            spec=lambda w: [_ER.problem_sets[w.er_path], _ER_SET["paths"][w.er_path]],
        log:
            f"{RESULTS}/erthal1992/logs/erthal_path_rows__{{er_path}}__{{robot}}.log",
        threads: 1
        resources:
            mem_mb=RES["light"]["mem_mb"],
            runtime=RES["light"]["runtime"],
        shell:
            "python -m pipeline erthal_path_rows --study {params.settings} --data {DATA} --problem-set {wildcards.er_path}"
            " --robot {wildcards.robot} --archive {input.archive} --out {output.rows} --res {output.res} > {log} 2>&1"
