# Study borges_kr6 (002_56eb235931bf5f5d.txt): one archive per method per problem set
# (alpha_sweep: JI only; points and paths: JI, LM, PSO; each PSO sensitivity variant on its problem_sets), then the generic tables/figures/report rules.
if "borges_kr6" in STUDIES:
    _KR6 = STUDIES["borges_kr6"]
    _KR6_ROBOT = _KR6.doc["robots"][0]
    from pipeline.studies.borges_kr6.run import PROBLEM_SETS as _KR6_SETS, set_methods as _kr6_set_methods

    _KR6_JOBS = [(s, m) for s in _KR6_SETS for m in _kr6_set_methods(s, _KR6.settings)]
    _KR6_METHODS = list(dict.fromkeys(m for _, m in _KR6_JOBS))

    STUDY_ARCHIVES["borges_kr6"] = [
        f"{RESULTS}/borges_kr6/runs/{s}__{m}.mcap" for s, m in _KR6_JOBS
    ]

    def _kr6_job_settings(w):
        from pipeline.studies.borges_kr6.run import job_settings

        return json.dumps(job_settings(_KR6.settings, w.pset, w.method, SCALE), sort_keys=True)

    rule solve_borges_kr6:
        input:
            robot=f"{DATA}/robots/{_KR6_ROBOT}.yaml",
        output:
            f"{RESULTS}/borges_kr6/runs/{{pset}}__{{method}}.mcap",
        wildcard_constraints:
            pset="alpha_sweep|points|paths",
            method="|".join(_KR6_METHODS),
        params:
            settings=f"{DATA}/studies/borges_kr6.yaml",
            job=_kr6_job_settings,
            scale=SCALE,
        log:
            f"{RESULTS}/borges_kr6/logs/solve_borges_kr6__{{pset}}__{{method}}.log",
        benchmark:
            f"{RESULTS}/borges_kr6/benchmarks/{{pset}}__{{method}}.tsv"
        shell:
            "{ENV} python -m pipeline solve_borges_kr6 --study {params.settings} --robot {input.robot}"
            " --set {wildcards.pset} --method {wildcards.method} --scale {params.scale}"
            " --out {output} > {log} 2>&1"
