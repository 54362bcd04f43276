# Problem sets and solve jobs: one rule each for every study (problem_sets x robots x solvers of
# data/studies/<id>.yaml). Each solve job runs one registered solver on one problem file.


rule make_problems:
    input:
        robot=f"{DATA}/robots/{{robot}}.yaml",
        files=problem_set_files,
    output:
        f"{RESULTS}/{{study}}/problems/{{pset}}/{{robot}}.csv",
    wildcard_constraints:
        study=GENERIC_STUDIES,
    params:
        settings=study_file,
        spec=lambda w: STUDIES[w.study].problem_sets[w.pset],  # a changed spec re-draws the set
        n_problems=lambda w: STUDIES[w.study].count(w.pset, SCALE),
        scale=SCALE,
    log:
        f"{RESULTS}/{{study}}/logs/make_problems__{{pset}}__{{robot}}.log",
    shell:
        "python -m pipeline make_problems --study {params.settings} --problem-set {wildcards.pset}"
        " --robot {input.robot} --scale {params.scale} --data {DATA} --out {output} > {log} 2>&1"


rule solve_problems:
    input:
        problems=f"{RESULTS}/{{study}}/problems/{{pset}}/{{robot}}.csv",
        robot=f"{DATA}/robots/{{robot}}.yaml",
    output:
        f"{RESULTS}/{{study}}/runs/{{pset}}/{{robot}}__{{solver}}.mcap",
    wildcard_constraints:
        study=GENERIC_STUDIES,
    params:
        settings=study_file,
        solver=lambda w: STUDIES[w.study].solvers[w.solver].as_dict(),  # a changed setting re-runs the job
        repetitions=lambda w: STUDIES[w.study].repetitions(w.pset, SCALE),
        scale=SCALE,
    log:
        f"{RESULTS}/{{study}}/logs/solve_problems__{{pset}}__{{robot}}__{{solver}}.log",
    benchmark:
        f"{RESULTS}/{{study}}/benchmarks/{{pset}}__{{robot}}__{{solver}}.tsv"
    shell:
        "{ENV} python -m pipeline solve_problems --study {params.settings} --problem-set {wildcards.pset}"
        " --robot {input.robot} --solver {wildcards.solver} --problems {input.problems}"
        " --scale {params.scale} --out {output} > {log} 2>&1"
