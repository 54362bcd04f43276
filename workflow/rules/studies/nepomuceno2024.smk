# nepomuceno2024 (004_957b32c2b06ea31d.txt): one archive per (motion, method); every point of a
# designed UR5 motion solved `repetitions` times. Tables and figures come from the generic rules.
if "nepomuceno2024" in STUDIES:
    _NEP = STUDIES["nepomuceno2024"].settings
    _NEP_METHODS = list(_NEP["methods"])
    STUDY_ARCHIVES["nepomuceno2024"] = [
        f"{RESULTS}/nepomuceno2024/runs/{motion}__{method}.mcap"
        for motion in _NEP["motions"]
        for method in _NEP_METHODS
    ]

    rule solve_motion_nepomuceno2024:
        input:
            robot=f"{DATA}/robots/{_NEP['robot']}.yaml",
            motions=f"{DATA}/{_NEP['motions_file']}",
        output:
            f"{RESULTS}/nepomuceno2024/runs/{{motion}}__{{method}}.mcap",
        wildcard_constraints:
            motion="|".join(_NEP["motions"]),
            method="|".join(_NEP_METHODS),
        params:
            settings=f"{DATA}/studies/nepomuceno2024.yaml",
            method=lambda w: _NEP["methods"][w.method],
            shared={k: _NEP[k] for k in ("costs", "success")},
            interpolation=_NEP["interpolation"][SCALE],
            repetitions=_NEP["repetitions"][SCALE],
            scale=SCALE,
        log:
            f"{RESULTS}/nepomuceno2024/logs/solve_motion__{{motion}}__{{method}}.log",
        benchmark:
            f"{RESULTS}/nepomuceno2024/benchmarks/{{motion}}__{{method}}.tsv"
        shell:
            "{ENV} python -m pipeline solve_motion_nepomuceno2024 --study {params.settings}"
            " --robot {input.robot} --motions {input.motions} --motion {wildcards.motion}"
            " --method {wildcards.method} --scale {params.scale} --out {output} > {log} 2>&1"
