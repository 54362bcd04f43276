# The answer's race (pipeline/jobs/race.py): after an arm's solve jobs, its finalists (the labels left
# to choose from once the archives have decided correctness) are timed against each other in one
# process, interleaved, into results/<study>/race/<robot>.mcap, which the study's tables read. A study
# asks for it by listing `race/{robot}.mcap` under `archives` (arm_benchmark.yaml does; `new_study
# --protocol answer` copies it): one race per arm with a solve job.


rule race:
    input:
        archives=race_archives,
        robot=f"{DATA}/robots/{{robot}}.yaml",
    output:
        f"{RESULTS}/{{study}}/race/{{robot}}.mcap",
    log:
        f"{RESULTS}/{{study}}/logs/race__{{robot}}.log",
    benchmark:
        f"{RESULTS}/{{study}}/benchmarks/race__{{robot}}.tsv"
    threads: 1
    resources:
        mem_mb=RES["solve_robot"]["mem_mb"],
        runtime=RES["solve_robot"]["runtime"],
    params:
        settings=study_file,
        env=ENV,
    shell:
        "{params.env} python -m pipeline race --study {params.settings} --robot {input.robot}"
        " --archives {input.archives} --out {output} > {log} 2>&1"
