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
    shell:
        "{ENV} python -m pipeline compile --studies {input.studies} --data {DATA} > {output} 2> {log}"


rule make_problems:
    input:
        robot=f"{DATA}/robots/{{robot}}.yaml",
        files=problem_set_files,
    output:
        f"{RESULTS}/{{study}}/problems/{{pset}}/{{robot}}.csv.gz",
    wildcard_constraints:
        study=GENERIC_STUDIES,
    params:
        settings=study_file,
        spec=lambda w: STUDIES[w.study].problem_sets[w.pset],  # a changed spec re-draws the set
        n_problems=lambda w: STUDIES[w.study].count(w.pset, SCALE),
        scale=SCALE,
    log:
        f"{RESULTS}/{{study}}/logs/make_problems__{{pset}}__{{robot}}.log",
    threads: 1
    resources:
        mem_mb=RES["light"]["mem_mb"],
        runtime=RES["light"]["runtime"],
    shell:
        "python -m pipeline make_problems --study {params.settings} --problem-set {wildcards.pset}"
        " --robot {input.robot} --scale {params.scale} --data {DATA} --out {output} > {log} 2>&1"


rule solve_problems:
    input:
        problems=f"{RESULTS}/{{study}}/problems/{{pset}}/{{robot}}.csv.gz",
        robot=f"{DATA}/robots/{{robot}}.yaml",
        kernels=ancient(KERNELS),
    output:
        f"{RESULTS}/{{study}}/runs/{{pset}}/{{robot}}__{{solver}}.mcap",
    wildcard_constraints:
        study=SOLO_STUDIES,
    params:
        settings=study_file,
        solver=lambda w: STUDIES[w.study].solvers[w.solver].as_dict(),  # a changed setting re-runs the job
        repetitions=lambda w: STUDIES[w.study].repetitions(w.pset, SCALE),
        scale=SCALE,
    log:
        f"{RESULTS}/{{study}}/logs/solve_problems__{{pset}}__{{robot}}__{{solver}}.log",
    benchmark:
        f"{RESULTS}/{{study}}/benchmarks/{{pset}}__{{robot}}__{{solver}}.tsv"
    threads: 1
    resources:
        mem_mb=RES["solve"]["mem_mb"],
        runtime=RES["solve"]["runtime"],
    shell:
        "{ENV} python -m pipeline solve_problems --study {params.settings} --problem-set {wildcards.pset}"
        " --robot {input.robot} --solver {wildcards.solver} --problems {input.problems}"
        " --scale {params.scale} --out {output} > {log} 2>&1"


# A study with `job_per_robot: true` runs every solver of every problem set of a robot in one job
# (one process start and one kernel warm-up per robot): one rule per robot, since the solver labels
# that apply differ from robot to robot. The archives are the same files (and contents, timings
# aside) as one job per solver would write.
for _sid in PER_ROBOT_STUDIES:
    _st = STUDIES[_sid]
    for _robot in dict.fromkeys(r for _p in _st.problem_sets for r in _st.set_robots(_p)):
        _sets = [_p for _p in _st.problem_sets if _robot in _st.set_robots(_p)]
        _labels = _st.robot_solvers(_sets[0], _robot)
        if not _labels:
            continue
        if any(_st.robot_solvers(_p, _robot) != _labels for _p in _sets):
            sys.exit(f"error: {_st.path}: job_per_robot needs the same solvers on every problem set of {_robot}")

        rule:
            name:
                f"solve_{_sid}__{_robot}"
            input:
                problems=[f"{RESULTS}/{_sid}/problems/{_p}/{_robot}.csv.gz" for _p in _sets],
                robot=f"{DATA}/robots/{_robot}.yaml",
                kernels=ancient(KERNELS),
            output:
                [f"{RESULTS}/{_sid}/runs/{_p}/{_robot}__{lab}.mcap" for _p in _sets for lab in _labels],
            params:
                settings=f"{DATA}/studies/{_sid}.yaml",
                # a changed setting of any solver re-runs the job
                solvers=[_st.solvers[lab].as_dict() for lab in _labels],
                caps=[[_st.solver_cap(_p, lab, SCALE) for lab in _labels] for _p in _sets],
                labels=" ".join(_labels),
                psets=" ".join(_sets),
                scale=SCALE,
            log:
                f"{RESULTS}/{_sid}/logs/solve_problems__{_robot}.log",
            benchmark:
                f"{RESULTS}/{_sid}/benchmarks/{_robot}.tsv"
            threads: 1
            resources:
                mem_mb=RES["solve_robot"]["mem_mb"],
                runtime=RES["solve_robot"]["runtime"],
            shell:
                "{ENV} python -m pipeline solve_problems --study {params.settings} --problem-set {params.psets}"
                " --robot {input.robot} --solver {params.labels} --problems {input.problems}"
                " --scale {params.scale} --out {output} > {log} 2>&1"
