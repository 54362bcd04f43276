# cerbaro2019 beyond the generic solve jobs: the Table 16 rerun of each default-reading solver's
# failed problems (codes 2 and 3 off, 4 000-iteration cap), archived as its own job. The study's
# settings list the reruns under `archives` (`reruns/{pset}/{robot}__{solver}.mcap`, default reading).


rule rerun_failures:
    input:
        problems=f"{RESULTS}/cerbaro2019/problems/{{pset}}/{{robot}}.csv.gz",
        robot=f"{DATA}/robots/{{robot}}.yaml",
        archive=f"{RESULTS}/cerbaro2019/runs/{{pset}}/{{robot}}__{{solver}}.mcap",
    output:
        f"{RESULTS}/cerbaro2019/reruns/{{pset}}/{{robot}}__{{solver}}.mcap",
    log:
        f"{RESULTS}/cerbaro2019/logs/rerun_failures__{{pset}}__{{robot}}__{{solver}}.log",
    benchmark:
        f"{RESULTS}/cerbaro2019/benchmarks/rerun__{{pset}}__{{robot}}__{{solver}}.tsv"
    threads: 1
    resources:
        mem_mb=RES["solve"]["mem_mb"],
        runtime=RES["solve"]["runtime"],
    params:
        settings=f"{DATA}/studies/cerbaro2019.yaml",
        rerun=lambda w: study_settings("cerbaro2019")["rerun"],
        solver=lambda w: STUDIES["cerbaro2019"]["solvers"][w.solver],
        scale=SCALE,
        env=ENV,
    shell:
        "{params.env} python -m pipeline rerun_failures --study {params.settings} --problem-set {wildcards.pset}"
        " --robot {input.robot} --solver {wildcards.solver} --problems {input.problems}"
        " --archive {input.archive} --scale {params.scale} --out {output} > {log} 2>&1"
