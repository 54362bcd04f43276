# Study erthal1992 (001_7601717b50b5e768.txt) beyond the generic solve jobs (Tests 1, 2, 3, 5, 6, the
# SCARA paths and the analytic PUMA are problem sets solved by the registered solvers): the catalogue
# conversions and the RES files of the path tasks, written from their solve archives (no solving). The
# study's settings list both under `archives`; problem sets listed in
# study_settings/full_only_problem_sets run only at scale=full.


rule erthal_catalogue:
    input:
        robots=lambda w: [
            f"{DATA}/robots/{r}.yaml"
            for r in study_settings("erthal1992")["zero_positions"]
        ],
        joint_points=lambda w: [
            f"{DATA}/erthal1992/{f}"
            for f in study_settings("erthal1992").get("joint_point_inputs", [])
        ],
    output:
        archive=f"{RESULTS}/erthal1992/runs/catalogue.mcap",
        reports=directory(f"{RESULTS}/erthal1992/robots"),
    log:
        f"{RESULTS}/erthal1992/logs/erthal_catalogue.log",
    threads: 1
    resources:
        mem_mb=RES["solve"]["mem_mb"],
        runtime=RES["solve"]["runtime"],
    params:
        settings=f"{DATA}/studies/erthal1992.yaml",
        block=lambda w: erthal_catalogue_block(),
        data=data_dir,
    shell:
        "python -m pipeline erthal_catalogue --study {params.settings} --data {params.data}"
        " --out {output.archive} --report-dir {output.reports} > {log} 2>&1"


rule erthal_path_rows:
    input:
        archive=erthal_path_archive,
        task=lambda w: f"{DATA}/erthal1992/{study_doc('erthal1992')['problem_sets'][w.pset]['params']['task']}",
        robot=f"{DATA}/robots/{{robot}}.yaml",
    output:
        rows=f"{RESULTS}/erthal1992/paths/{{pset}}__{{robot}}.mcap",
        res=f"{RESULTS}/erthal1992/paths/{{pset}}__{{robot}}.RES",
    log:
        f"{RESULTS}/erthal1992/logs/erthal_path_rows__{{pset}}__{{robot}}.log",
    threads: 1
    resources:
        mem_mb=RES["light"]["mem_mb"],
        runtime=RES["light"]["runtime"],
    params:
        settings=f"{DATA}/studies/erthal1992.yaml",
        spec=lambda w: [
            study_doc("erthal1992")["problem_sets"][w.pset],
            study_settings("erthal1992")["paths"][w.pset],
        ],
        data=data_dir,
    shell:
        "python -m pipeline erthal_path_rows --study {params.settings} --data {params.data} --problem-set {wildcards.pset}"
        " --robot {wildcards.robot} --archive {input.archive} --out {output.rows} --res {output.res} > {log} 2>&1"
