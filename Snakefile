# Report pipeline: seeded problem sets -> one solve job per (study, robot, solver) writing MCAP ->
# tables and figures from the archives -> results/report.html. Rules live in workflow/rules/; the
# config, every study's settings and every robot file are validated first (workflow/rules/common.smk).
#
# `snakemake --lint` asks every rule for a conda environment or container, and nothing else: the rules run
# `python -m pipeline` in the one environment this project builds and tests, the venv installed from the
# hash-pinned requirements.lock (README set-up, CI); a conda file nothing here builds would be a second,
# untested description of it.
from snakemake.utils import min_version

min_version("8.20")


configfile: "workflow/config/config.yaml"


include: "workflow/rules/common.smk"
include: "workflow/rules/solve.smk"
include: "workflow/rules/report.smk"
# the rules of studies that make archives beyond the solve jobs (`archives` of their settings)
include: "workflow/rules/studies/arm_benchmark.smk"
include: "workflow/rules/studies/cerbaro2019.smk"
include: "workflow/rules/studies/erthal1992.smk"
include: "workflow/rules/studies/mariano2019.smk"


rule all:
    default_target: True
    input:
        all_targets(),
        f"{RESULTS}/MANIFEST.sha256",


# one study's archives, tables and figures: `snakemake --cores 2 results/cerbaro2019/.built` (a hidden
# stamp, outside the manifest)
rule study:
    input:
        study_inputs,
    output:
        touch(f"{RESULTS}/{{study}}/.built"),
