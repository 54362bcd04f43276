# Tables and figures per study (from archives only), then the HTML report.


rule aggregate_tables:
    input:
        study_archives,
    output:
        report(
            directory(f"{RESULTS}/{{study}}/tables"),
            patterns=["{name}.csv"],
            caption="../report/tables.rst",
            category="{study}",
            subcategory="tables",
        ),
    log:
        f"{RESULTS}/{{study}}/logs/aggregate_tables.log",
    threads: 1
    resources:
        mem_mb=RES["light"]["mem_mb"],
        runtime=RES["light"]["runtime"],
    params:
        settings=study_file,
        study=lambda w: study_doc(w.study),  # any settings change re-runs the tables
        published=f"{DATA}/published",
    shell:
        "python -m pipeline aggregate_tables --study {params.settings} --archives {input}"
        " --published {params.published} --out-dir {output} > {log} 2>&1"


rule plot_figures:
    input:
        study_archives,
    output:
        report(
            directory(f"{RESULTS}/{{study}}/figures"),
            patterns=["{name}.png"],
            caption="../report/figures.rst",
            category="{study}",
            subcategory="figures",
        ),
    log:
        f"{RESULTS}/{{study}}/logs/plot_figures.log",
    threads: 1
    resources:
        mem_mb=RES["figures"]["mem_mb"],
        runtime=RES["figures"]["runtime"],
    params:
        settings=study_file,
        study=lambda w: study_doc(w.study),
    shell:
        "python -m pipeline plot_figures --study {params.settings} --archives {input}"
        " --out-dir {output} > {log} 2>&1"


# The build fails on a number in a study's prose (claims' reasons, interpretations, notes, captions)
# that no bound cell, setting or document fact gives (pipeline/studies/prose.py); a hidden stamp
# (outside the manifest) records that the check passed.
rule check_prose:
    input:
        tables=f"{RESULTS}/{{study}}/tables",
        figures=f"{RESULTS}/{{study}}/figures",
    output:
        touch(f"{RESULTS}/{{study}}/.prose_checked"),
    log:
        f"{RESULTS}/{{study}}/logs/check_prose.log",
    threads: 1
    resources:
        mem_mb=RES["light"]["mem_mb"],
        runtime=RES["light"]["runtime"],
    params:
        settings=study_file,
        study=lambda w: study_doc(w.study),  # the prose is in the settings: a change re-runs the check
        built=lambda w: f"{RESULTS}/{w.study}",
        published=f"{DATA}/published",
    shell:
        "python -m pipeline check_prose --study {params.settings} --built {params.built}"
        " --published {params.published} > {log} 2>&1"


rule render_report:
    input:
        targets=[t for sid in STUDIES for t in study_targets(sid)],
        settings=[f"{DATA}/studies/{sid}.yaml" for sid in STUDIES],
        # the speed measurements of benchmarks/bench_fast.py (not rebuilt here: measured, committed)
        performance=[
            p for p in [f"{DATA}/performance/bench_fast.json"] if os.path.exists(p)
        ],
    output:
        report(
            f"{RESULTS}/report.html", caption="../report/report.rst", category="report"
        ),
    log:
        f"{RESULTS}/logs/render_report.log",
    threads: 1
    resources:
        mem_mb=RES["light"]["mem_mb"],
        runtime=RES["light"]["runtime"],
    params:
        sets=" ".join(
            f"--set {k}={json.dumps(v, separators=(',', ':'))}"
            for k, v in CONFIG.items()
        ),
    shell:
        "python -m pipeline render_report {params.sets} --out {output} > {log} 2>&1"


# The build's last step: the SHA-256 of every file it produced (archives, problem sets, tables, figures,
# the report; not logs or benchmarks), checked by `python -m pipeline verify` (pipeline/io/manifest.py).
rule manifest:
    input:
        all_targets(),
    output:
        f"{RESULTS}/MANIFEST.sha256",
    log:
        f"{RESULTS}/logs/manifest.log",
    threads: 1
    resources:
        mem_mb=RES["light"]["mem_mb"],
        runtime=RES["light"]["runtime"],
    params:
        results=lambda w: RESULTS,  # the folder it covers (a function: not a file of the job's own)
    shell:
        "python -m pipeline manifest {params.results} --out {output} > {log} 2>&1"
