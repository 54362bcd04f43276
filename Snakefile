# Report pipeline: seeded problem sets -> one solve job per (study, robot, solver) writing MCAP ->
# tables and figures from the archives -> results/report.html. Rules live in workflow/rules/; the
# config, every study's settings and every robot file are validated first (workflow/rules/common.smk).
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
