# Problem sets and solve jobs, generic over studies whose problems are random joint pairs.


rule make_problems:
    input:
        robot=f"{DATA}/robots/{{robot}}.yaml",
    output:
        f"{RESULTS}/{{study}}/problems/{{robot}}.csv",
    wildcard_constraints:
        study=GENERIC_STUDIES,
    params:
        settings=study_file,
        problems=lambda w: STUDIES[w.study].doc["problems"],
        n_problems=lambda w: STUDIES[w.study].count(SCALE),
        scale=SCALE,
    log:
        f"{RESULTS}/{{study}}/logs/make_problems__{{robot}}.log",
    shell:
        "python -m pipeline make_problems --study {params.settings} --robot {input.robot}"
        " --scale {params.scale} --out {output} > {log} 2>&1"


rule solve_problems:
    input:
        problems=f"{RESULTS}/{{study}}/problems/{{robot}}.csv",
        robot=f"{DATA}/robots/{{robot}}.yaml",
    output:
        f"{RESULTS}/{{study}}/runs/{{robot}}__{{solver}}.mcap",
    wildcard_constraints:
        study=GENERIC_STUDIES,
    params:
        settings=study_file,
        solver=lambda w: STUDIES[w.study].solvers[w.solver].as_dict(),
        scale=SCALE,
    log:
        f"{RESULTS}/{{study}}/logs/solve_problems__{{robot}}__{{solver}}.log",
    benchmark:
        f"{RESULTS}/{{study}}/benchmarks/{{robot}}__{{solver}}.tsv"
    shell:
        "{ENV} python -m pipeline solve_problems --study {params.settings} --robot {input.robot}"
        " --solver {wildcards.solver} --problems {input.problems} --scale {params.scale}"
        " --out {output} > {log} 2>&1"
