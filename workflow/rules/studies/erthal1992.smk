# Study erthal1992 (001_7601717b50b5e768.txt): catalogue conversions, IK tests, path tasks and the
# analytic PUMA, each one CLI verb writing an MCAP archive under results/erthal1992/runs/.
if "erthal1992" in STUDIES:
    _ER = STUDIES["erthal1992"]
    _ER_SET = _ER.settings
    _ER_RUNS = f"{RESULTS}/erthal1992/runs"
    _ER_FILE = f"{DATA}/studies/erthal1992.yaml"

    STUDY_ARCHIVES["erthal1992"] = (
        [f"{_ER_RUNS}/catalogue.mcap", f"{_ER_RUNS}/puma_analytic.mcap"]
        + [f"{_ER_RUNS}/{t}.mcap" for t in _ER_SET["tests"]]
        + [f"{_ER_RUNS}/path_{r}.mcap" for r, spec in _ER_SET["paths"].items()
           if SCALE == "full" or not spec.get("full_only", False)]
    )

    wildcard_constraints:
        er_test="|".join(_ER_SET["tests"]),
        er_run="|".join(_ER_SET["paths"]),

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
        shell:
            "python -m pipeline erthal_catalogue --study {params.settings} --data {DATA}"
            " --out {output.archive} --report-dir {output.reports} > {log} 2>&1"

    rule erthal_solve_test:
        input:
            robot=lambda w: f"{DATA}/robots/{_ER_SET['tests'][w.er_test]['robot']}.yaml",
            bases=f"{DATA}/erthal1992/robot_bases.yaml",
        output:
            f"{_ER_RUNS}/{{er_test}}.mcap",
        params:
            settings=_ER_FILE,
            block=lambda w: _ER_SET["tests"][w.er_test],
        log:
            f"{RESULTS}/erthal1992/logs/erthal_solve_test__{{er_test}}.log",
        benchmark:
            f"{RESULTS}/erthal1992/benchmarks/erthal_solve_test__{{er_test}}.tsv"
        shell:
            "{ENV} python -m pipeline erthal_solve_test --study {params.settings} --data {DATA}"
            " --test {wildcards.er_test} --out {output} > {log} 2>&1"

    rule erthal_solve_path:
        input:
            task=lambda w: f"{DATA}/erthal1992/{_ER_SET['paths'][w.er_run]['task']}",
            robots=[f"{DATA}/robots/{r}.yaml" for r in _ER.doc["robots"]],
            bases=f"{DATA}/erthal1992/robot_bases.yaml",
        output:
            archive=f"{_ER_RUNS}/path_{{er_run}}.mcap",
            res=f"{_ER_RUNS}/{{er_run}}.RES",
        params:
            settings=_ER_FILE,
            block=lambda w: _ER_SET["paths"][w.er_run],
        log:
            f"{RESULTS}/erthal1992/logs/erthal_solve_path__{{er_run}}.log",
        benchmark:
            f"{RESULTS}/erthal1992/benchmarks/erthal_solve_path__{{er_run}}.tsv"
        shell:
            "{ENV} python -m pipeline erthal_solve_path --study {params.settings} --data {DATA}"
            " --run {wildcards.er_run} --out {output.archive} --res {output.res} > {log} 2>&1"

    rule erthal_puma_analytic:
        input:
            robot=f"{DATA}/robots/puma560.yaml",
        output:
            f"{_ER_RUNS}/puma_analytic.mcap",
        params:
            settings=_ER_FILE,
            block=_ER_SET["puma_analytic"],
            scale=SCALE,
        log:
            f"{RESULTS}/erthal1992/logs/erthal_puma_analytic.log",
        benchmark:
            f"{RESULTS}/erthal1992/benchmarks/erthal_puma_analytic.tsv"
        shell:
            "{ENV} python -m pipeline erthal_puma_analytic --study {params.settings} --data {DATA}"
            " --scale {params.scale} --out {output} > {log} 2>&1"
