# Report pipeline: seeded problem sets -> one solve job per (study, robot, solver) writing MCAP ->
# tables and figures from the archives -> results/report.html. Rules live in workflow/rules/.
from pathlib import Path

from snakemake.utils import min_version

min_version("8.20")


configfile: "workflow/config/config.yaml"


include: "workflow/rules/common.smk"
include: "workflow/rules/solve.smk"
include: "workflow/rules/report.smk"


# studies with rules of their own; each file starts with `if "<id>" in STUDIES:`
for _rules in sorted(Path(workflow.basedir, "workflow/rules/studies").glob("*.smk")):

    include: str(_rules)



rule all:
    default_target: True
    input:
        all_targets(),


# one target per configured study: `snakemake --cores 2 cerbaro2019`
for _sid in STUDIES:

    rule:
        name:
            _sid
        input:
            study_targets(_sid),
            STUDY_ARCHIVES.get(_sid, []),
