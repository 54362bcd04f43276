# Study mariano2019 (003_8b306f4736fa5051.txt) beyond the generic solve jobs (the IK round trip is
# the problem set ik_roundtrip, solved by the registered analytic_4dof): operation counts, host FK
# timing (one archive per robot listed in study_settings/host_timing/robots) and the ATmega328P
# measurements (generated C, avr-gcc, simavr); the study's settings list the three under `archives`.
# The MCU job never fails for a missing toolchain: its archive then says "not measured" and the tables
# show how to enable it.


rule mariano_count_ops:
    input:
        robot=lambda w: f"{DATA}/robots/{mariano_arm()}.yaml",
    output:
        f"{RESULTS}/mariano2019/runs/counts.mcap",
    log:
        f"{RESULTS}/mariano2019/logs/mariano_count_ops.log",
    benchmark:
        f"{RESULTS}/mariano2019/benchmarks/mariano_count_ops.tsv"
    threads: 1
    resources:
        mem_mb=RES["solve"]["mem_mb"],
        runtime=RES["solve"]["runtime"],
    params:
        settings=f"{DATA}/studies/mariano2019.yaml",
        block=lambda w: mariano_block("counting"),
        scale=SCALE,
        env=ENV,
    shell:
        "{params.env} python -m pipeline mariano_count_ops --study {params.settings} --robot {input.robot}"
        " --scale {params.scale} --out {output} > {log} 2>&1"


rule mariano_time_host:
    input:
        robot=f"{DATA}/robots/{{robot}}.yaml",
    output:
        f"{RESULTS}/mariano2019/runs/host_{{robot}}.mcap",
    log:
        f"{RESULTS}/mariano2019/logs/mariano_time_host__{{robot}}.log",
    benchmark:
        f"{RESULTS}/mariano2019/benchmarks/mariano_time_host__{{robot}}.tsv"
    threads: 1
    resources:
        mem_mb=RES["solve"]["mem_mb"],
        runtime=RES["solve"]["runtime"],
    params:
        settings=f"{DATA}/studies/mariano2019.yaml",
        block=lambda w: mariano_block("host_timing"),
        scale=SCALE,
        env=ENV,
    shell:
        "{params.env} python -m pipeline mariano_time_host --study {params.settings} --robot {input.robot}"
        " --scale {params.scale} --out {output} > {log} 2>&1"


rule mariano_measure_mcu:
    input:
        robot=lambda w: f"{DATA}/robots/{mariano_arm()}.yaml",
    output:
        f"{RESULTS}/mariano2019/runs/mcu.mcap",
    log:
        f"{RESULTS}/mariano2019/logs/mariano_measure_mcu.log",
    benchmark:
        f"{RESULTS}/mariano2019/benchmarks/mariano_measure_mcu.tsv"
    threads: 1
    resources:
        mem_mb=RES["solve"]["mem_mb"],
        runtime=RES["solve"]["runtime"],
    params:
        settings=f"{DATA}/studies/mariano2019.yaml",
        block=lambda w: mariano_block("mcu"),
        scale=SCALE,
        build_dir=f"{RESULTS}/mariano2019/mcu_build",
    shell:
        "python -m pipeline mariano_measure_mcu --study {params.settings} --robot {input.robot}"
        " --scale {params.scale} --build-dir {params.build_dir} --out {output} > {log} 2>&1"
