# Problem sets and solve jobs: one rule each for every study (problem_sets x robots x solvers of
# data/studies/<id>.yaml). Each solve job runs one registered solver on one problem file.


# Kernels first: `python -m pipeline compile --studies` warms numba's cache with what every solve job of
# the configured studies calls, so that no solve job compiles and no two jobs compile the same kernel at
# once. Its output is a hidden stamp (outside the manifest); the solve rules take it as an `ancient`
# input, so that a re-run of this rule (a changed study file) re-runs no solve.
KERNELS = f"{RESULTS}/.kernels/compiled.txt"


rule compile_kernels:
    input:
        studies=[f"{DATA}/studies/{sid}.yaml" for sid in STUDIES],
    output:
        KERNELS,
    log:
        f"{RESULTS}/.kernels/compile_kernels.log",
    benchmark:
        f"{RESULTS}/.kernels/compile_kernels.tsv"
    threads: 1
    resources:
        mem_mb=RES["solve_robot"]["mem_mb"],
        runtime=RES["solve_robot"]["runtime"],
    params:
        env=ENV,
        data=data_dir,
    shell:
        "{params.env} python -m pipeline compile --studies {input.studies} --data {params.data} > {output} 2> {log}"


rule make_problems:
    input:
        robot=f"{DATA}/robots/{{robot}}.yaml",
        files=problem_set_files,
    output:
        f"{RESULTS}/{{study}}/problems/{{pset}}/{{robot}}.csv.gz",
    log:
        f"{RESULTS}/{{study}}/logs/make_problems__{{pset}}__{{robot}}.log",
    wildcard_constraints:
        study=_alternatives(sid for sid in STUDIES if _generic(sid)),
    threads: 1
    resources:
        mem_mb=RES["light"]["mem_mb"],
        runtime=RES["light"]["runtime"],
    params:
        settings=study_file,
        spec=lambda w: study_doc(w.study)["problem_sets"][w.pset],  # a changed spec re-draws the set
        n_problems=lambda w: STUDIES[w.study]["count"][w.pset],
        scale=SCALE,
        data=data_dir,
    shell:
        "python -m pipeline make_problems --study {params.settings} --problem-set {wildcards.pset}"
        " --robot {input.robot} --scale {params.scale} --data {params.data} --out {output} > {log} 2>&1"


rule solve_problems:
    input:
        problems=f"{RESULTS}/{{study}}/problems/{{pset}}/{{robot}}.csv.gz",
        robot=f"{DATA}/robots/{{robot}}.yaml",
        kernels=ancient(KERNELS),
    output:
        f"{RESULTS}/{{study}}/runs/{{pset}}/{{robot}}__{{solver}}.mcap",
    log:
        f"{RESULTS}/{{study}}/logs/solve_problems__{{pset}}__{{robot}}__{{solver}}.log",
    benchmark:
        f"{RESULTS}/{{study}}/benchmarks/{{pset}}__{{robot}}__{{solver}}.tsv"
    wildcard_constraints:
        study=SOLO_STUDIES,
    threads: 1
    resources:
        mem_mb=RES["solve"]["mem_mb"],
        runtime=RES["solve"]["runtime"],
    params:
        settings=study_file,
        solver=lambda w: STUDIES[w.study]["solvers"][w.solver],  # a changed setting re-runs the job
        repetitions=lambda w: STUDIES[w.study]["repetitions"][w.pset],
        scale=SCALE,
        env=ENV,
    shell:
        "{params.env} python -m pipeline solve_problems --study {params.settings} --problem-set {wildcards.pset}"
        " --robot {input.robot} --solver {wildcards.solver} --problems {input.problems}"
        " --scale {params.scale} --out {output} > {log} 2>&1"


# A study with `job_per_robot: true` runs every solver of every problem set of a robot in one job
# (one process start and one kernel warm-up per robot), writing the same archives (and contents, timings
# aside) as one job per solver would. The one rule made in a loop: a Snakemake job's outputs are its
# rule's output patterns, so a job whose archives differ in number from robot to robot (the solvers that
# apply differ) needs a rule of its own; `group:` would keep the jobs together on a cluster but not
# in one process.
for _sid, _robot in dict.fromkeys(
    (sid, r)
    for sid in PER_ROBOT_STUDIES
    for p in study_doc(sid)["problem_sets"]
    for r in set_robots(sid, p)
):
    _sets = robot_sets(_sid, _robot)
    _labels = robot_solvers(_sid, _sets[0], _robot)
    if not _labels:
        continue
    if any(robot_solvers(_sid, p, _robot) != _labels for p in _sets):
        sys.exit(
            f"error: {DATA}/studies/{_sid}.yaml: job_per_robot needs the same solvers on every problem set of {_robot}"
        )

    rule:
        name:
            f"solve_{_sid}__{_robot}"
        input:
            problems=[f"{RESULTS}/{_sid}/problems/{p}/{_robot}.csv.gz" for p in _sets],
            robot=f"{DATA}/robots/{_robot}.yaml",
            kernels=ancient(KERNELS),
        output:
            [
                f"{RESULTS}/{_sid}/runs/{p}/{_robot}__{lab}.mcap"
                for p in _sets
                for lab in _labels
            ],
        log:
            f"{RESULTS}/{_sid}/logs/solve_problems__{_robot}.log",
        benchmark:
            f"{RESULTS}/{_sid}/benchmarks/{_robot}.tsv"
        threads: 1
        resources:
            mem_mb=RES["solve_robot"]["mem_mb"],
            runtime=RES["solve_robot"]["runtime"],
        params:
            settings=f"{DATA}/studies/{_sid}.yaml",
            # a changed setting of any solver re-runs the job
            solvers=[STUDIES[_sid]["solvers"][lab] for lab in _labels],
            caps=[[STUDIES[_sid]["caps"][p][lab] for lab in _labels] for p in _sets],
            labels=" ".join(_labels),
            psets=" ".join(_sets),
            scale=SCALE,
            env=ENV,
        shell:
            "{params.env} python -m pipeline solve_problems --study {params.settings} --problem-set {params.psets}"
            " --robot {input.robot} --solver {params.labels} --problems {input.problems}"
            " --scale {params.scale} --out {output} > {log} 2>&1"
