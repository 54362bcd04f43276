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
# aside) as one job per solver would. A Snakemake job's outputs are its rule's output patterns and the
# archives of a robot differ in number from robot to robot (the solvers that apply differ), so the job
# writes them into a hidden folder of its own, results/<study>/.runs_<robot>/<set>/ (`directory()`, outside
# the manifest, at the depth of runs/<set>/ so that the problem and robot paths an archive records relative
# to itself hold in both places), and `place_archive` hard-links each one to its place under runs/ (one
# local job per archive: an `ln`, no Python process).
rule solve_robot:
    input:
        problems=robot_problem_files,
        robot=f"{DATA}/robots/{{robot}}.yaml",
        kernels=ancient(KERNELS),
    output:
        directory(f"{RESULTS}/{{study}}/.runs_{{robot}}"),
    log:
        f"{RESULTS}/{{study}}/logs/solve_problems__{{robot}}.log",
    benchmark:
        f"{RESULTS}/{{study}}/benchmarks/{{robot}}.tsv"
    wildcard_constraints:
        study=_alternatives(PER_ROBOT_STUDIES),
    threads: 1
    resources:
        mem_mb=RES["solve_robot"]["mem_mb"],
        runtime=RES["solve_robot"]["runtime"],
    params:
        settings=study_file,
        # a changed setting of any solver re-runs the job
        solvers=lambda w: [STUDIES[w.study]["solvers"][lab] for lab in robot_labels(w.study, w.robot)],
        caps=lambda w: [
            [STUDIES[w.study]["caps"][p][lab] for lab in robot_labels(w.study, w.robot)]
            for p in robot_sets(w.study, w.robot)
        ],
        labels=lambda w: " ".join(robot_labels(w.study, w.robot)),
        psets=lambda w: " ".join(robot_sets(w.study, w.robot)),
        out=robot_job_archives,
        scale=SCALE,
        env=ENV,
    shell:
        "{params.env} python -m pipeline solve_problems --study {params.settings} --problem-set {params.psets}"
        " --robot {input.robot} --solver {params.labels} --problems {input.problems}"
        " --scale {params.scale} --out {params.out} > {log} 2>&1"


rule place_archive:
    input:
        f"{RESULTS}/{{study}}/.runs_{{robot}}",
    output:
        f"{RESULTS}/{{study}}/runs/{{pset}}/{{robot}}__{{solver}}.mcap",
    log:
        f"{RESULTS}/{{study}}/logs/place_archive__{{pset}}__{{robot}}__{{solver}}.log",
    wildcard_constraints:
        study=_alternatives(PER_ROBOT_STUDIES),
    threads: 1
    resources:
        mem_mb=RES["light"]["mem_mb"],
        runtime=RES["light"]["runtime"],
    params:
        archive=lambda w, input: f"{input[0]}/{w.pset}/{w.robot}__{w.solver}.mcap",
    shell:
        "(ln -f {params.archive:q} {output:q} || cp -p {params.archive:q} {output:q}) > {log:q} 2>&1"
