# Study mariano2019 (003_8b306f4736fa5051.txt) beyond the generic solve jobs (the IK round trip is
# the problem set ik_roundtrip, solved by the registered analytic_4dof): operation counts, host FK
# timing (one archive per robot listed in study_settings/host_timing/robots) and the ATmega328P
# measurements (generated C, avr-gcc, simavr). The MCU job never fails for a missing toolchain: its
# archive then says "not measured" and the tables show how to enable it.
if "mariano2019" in STUDIES:
    _MAR = STUDIES["mariano2019"]
    _MAR_S = _MAR.settings
    _MAR_ARM = _MAR_S.get("arm", "mariano_4dof")
    MARIANO_HOST_ROBOTS = list(_MAR_S["host_timing"]["robots"])

    def _mar_scaled(block):
        return {
            k: (v[SCALE] if isinstance(v, dict) and set(v) == {"full", "quick"} else v)
            for k, v in _MAR_S[block].items()
        }

    STUDY_ARCHIVES["mariano2019"] = STUDY_ARCHIVES["mariano2019"] + [
        f"{RESULTS}/mariano2019/runs/counts.mcap",
        f"{RESULTS}/mariano2019/runs/mcu.mcap",
    ] + [f"{RESULTS}/mariano2019/runs/host_{r}.mcap" for r in MARIANO_HOST_ROBOTS]

    rule mariano_count_ops:
        input:
            robot=f"{DATA}/robots/{_MAR_ARM}.yaml",
        output:
            f"{RESULTS}/mariano2019/runs/counts.mcap",
        params:
            settings=f"{DATA}/studies/mariano2019.yaml",
            block=_mar_scaled("counting"),
            scale=SCALE,
        log:
            f"{RESULTS}/mariano2019/logs/mariano_count_ops.log",
        benchmark:
            f"{RESULTS}/mariano2019/benchmarks/mariano_count_ops.tsv"
        threads: 1
        resources:
            mem_mb=RES["solve"]["mem_mb"],
            runtime=RES["solve"]["runtime"],
        shell:
            "{ENV} python -m pipeline mariano_count_ops --study {params.settings} --robot {input.robot}"
            " --scale {params.scale} --out {output} > {log} 2>&1"

    rule mariano_time_host:
        input:
            robot=f"{DATA}/robots/{{robot}}.yaml",
        output:
            f"{RESULTS}/mariano2019/runs/host_{{robot}}.mcap",
        params:
            settings=f"{DATA}/studies/mariano2019.yaml",
            block=_mar_scaled("host_timing"),
            scale=SCALE,
        log:
            f"{RESULTS}/mariano2019/logs/mariano_time_host__{{robot}}.log",
        benchmark:
            f"{RESULTS}/mariano2019/benchmarks/mariano_time_host__{{robot}}.tsv"
        threads: 1
        resources:
            mem_mb=RES["solve"]["mem_mb"],
            runtime=RES["solve"]["runtime"],
        shell:
            "{ENV} python -m pipeline mariano_time_host --study {params.settings} --robot {input.robot}"
            " --scale {params.scale} --out {output} > {log} 2>&1"

    rule mariano_measure_mcu:
        input:
            robot=f"{DATA}/robots/{_MAR_ARM}.yaml",
        output:
            f"{RESULTS}/mariano2019/runs/mcu.mcap",
        params:
            settings=f"{DATA}/studies/mariano2019.yaml",
            block=_mar_scaled("mcu"),
            scale=SCALE,
            build_dir=f"{RESULTS}/mariano2019/mcu_build",
        log:
            f"{RESULTS}/mariano2019/logs/mariano_measure_mcu.log",
        benchmark:
            f"{RESULTS}/mariano2019/benchmarks/mariano_measure_mcu.tsv"
        threads: 1
        resources:
            mem_mb=RES["solve"]["mem_mb"],
            runtime=RES["solve"]["runtime"],
        shell:
            "python -m pipeline mariano_measure_mcu --study {params.settings} --robot {input.robot}"
            " --scale {params.scale} --build-dir {params.build_dir} --out {output} > {log} 2>&1"
