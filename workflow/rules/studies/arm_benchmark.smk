# The answer's race (pipeline/jobs/race.py): after an arm's solve jobs, its finalists (the labels left
# to choose from once the archives have decided correctness) are timed against each other in one
# process, interleaved, into results/<study>/race/<robot>.mcap, which the study's tables read. Every
# study with the answer's protocol (arm_benchmark, or `tables_from: arm_benchmark`) gets one per arm.
for _sid in [s for s, st in STUDIES.items() if (st.doc.get("tables_from") or s) == "arm_benchmark"]:
    _st = STUDIES[_sid]
    _robots = list(dict.fromkeys(r for _p in _st.problem_sets for r in _st.set_robots(_p)))
    _races = []
    for _robot in _robots:
        _runs = [a for a in STUDY_ARCHIVES[_sid] if a.split("/")[-1].startswith(f"{_robot}__")]
        if not _runs:
            continue
        _races.append(f"{RESULTS}/{_sid}/race/{_robot}.mcap")

        rule:
            name:
                f"race_{_sid}__{_robot}"
            input:
                archives=_runs,
                robot=f"{DATA}/robots/{_robot}.yaml",
            output:
                f"{RESULTS}/{_sid}/race/{_robot}.mcap",
            params:
                settings=f"{DATA}/studies/{_sid}.yaml",
            log:
                f"{RESULTS}/{_sid}/logs/race__{_robot}.log",
            benchmark:
                f"{RESULTS}/{_sid}/benchmarks/race__{_robot}.tsv"
            threads: 1
            resources:
                mem_mb=RES["solve_robot"]["mem_mb"],
                runtime=RES["solve_robot"]["runtime"],
            shell:
                "{ENV} python -m pipeline race --study {params.settings} --robot {input.robot}"
                " --archives {input.archives} --out {output} > {log} 2>&1"

    STUDY_ARCHIVES[_sid] = STUDY_ARCHIVES[_sid] + _races
