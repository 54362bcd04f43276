# Report pipeline: seeded problem sets -> one solve job per (study, robot, solver) writing MCAP ->
# tables and figures from the archives -> results/report.html. Rules live in workflow/rules/.
from pathlib import Path

from snakemake.utils import min_version

min_version("8.20")


configfile: "workflow/config/config.yaml"


# Config validation, first part: every config file (this one and each --configfile) through the one YAML
# loader and the schema, so that an error names the file that holds it; what is left comes from --config.
# (workflow/rules/common.smk then validates the studies and robots.)
import sys

from pipeline.settings import ConfigError, check_config_files

try:
    check_config_files(["workflow/config/config.yaml", *workflow.overwrite_configfiles], config)
except ConfigError as exc:
    sys.exit(f"error: {exc}")


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
        f"{RESULTS}/MANIFEST.sha256",


# one target per configured study: `snakemake --cores 2 cerbaro2019`
for _sid in STUDIES:

    rule:
        name:
            _sid
        input:
            study_targets(_sid),
            STUDY_ARCHIVES.get(_sid, []),
