# Report pipeline: seeded problem sets -> one solve job per (study, robot, solver) writing MCAP ->
# tables and figures from the archives -> results/report.html. Rules live in workflow/rules/.
from snakemake.utils import min_version

min_version("8.20")


configfile: "workflow/config/config.yaml"


include: "workflow/rules/common.smk"
include: "workflow/rules/solve.smk"
include: "workflow/rules/report.smk"


rule all:
    default_target: True
    input:
        f"{RESULTS}/report.html",
