"""Numbers in a study's prose come from its tables (pipeline.studies.prose): placeholders are filled at
build time, and a number no table, setting or listed fact holds is reported (the built report's check
runs in tests/workflow/test_workflow.py)."""

from __future__ import annotations

import json
from types import SimpleNamespace

import pandas as pd
import pytest

from pipeline.studies.prose import MISSING_VALUE, ProseError, fill, untabled_numbers

T = {"t": pd.DataFrame({"method": ["A", "B"], "statistic": ["mean", "mean"], "v (ours)": [48.312, 12345.6]})}


def test_fill_formats_table_values_and_marks_missing_rows():
    assert fill("x {{ t | A | v (ours) | .1f }} y", T) == "x 48.3 y"
    assert fill("{{t|B|v (ours)|,.0f}}", T) == "12,346"
    assert fill("{{ t | method=B, statistic=mean | v (ours) }}", T) == "1.235e+04"
    assert fill("{{ t | Z | v (ours) }} and {{ absent | A | v }}", T) == f"{MISSING_VALUE} and {MISSING_VALUE}"
    with pytest.raises(ProseError, match="no column 'w'"):
        fill("{{ t | A | w }}", T)


def _built(tmp_path, note: str, evidence: str, facts=()):
    folder = tmp_path / "s"
    (folder / "tables").mkdir(parents=True)
    T["t"].to_csv(folder / "tables" / "t.csv", index=False)
    (folder / "tables" / "index.json").write_text(json.dumps([{"name": "t", "title": "T", "note": note, "file": "t.csv"}]))
    study = SimpleNamespace(id="s", doc={"interpretations": [{"topic": "x", "choice": "c", "evidence": evidence}],
                                         "solvers": {"a": {"max_iterations": 500}}, "prose_facts": list(facts)})
    return study, folder


def test_a_hand_typed_result_is_caught_and_tabled_numbers_pass(tmp_path):
    study, folder = _built(tmp_path, "A took 48.3 s (Table 7, eq. 47, UR5, 6-DoF), cap 500.",
                           "B: {{ t | B | v (ours) | ,.0f }}; was 5.4 ms against 0.021")
    bad = untabled_numbers(study, folder, tmp_path / "published")
    assert [b[1] for b in bad] == ["5.4", "0.021"], bad
    assert bad[0][0] == "interpretation 'x' (evidence)"


def test_listed_document_facts_pass(tmp_path):
    study, folder = _built(tmp_path, "Eberhart & Shi 2001", "", facts=[2001])
    assert untabled_numbers(study, folder, tmp_path / "published") == []
    study, folder = _built(tmp_path / "b", "Eberhart & Shi 2001", "")
    assert [b[1] for b in untabled_numbers(study, folder, tmp_path / "published")] == ["2001"]


def test_a_typed_number_in_the_study_file_is_not_held_by_some_cell_of_ours(tmp_path):
    """Issue 45: in a reason or interpretation a number about our results must come from the cell the
    placeholder names; typed by hand it fails even where it equals some cell of the study."""
    study, folder = _built(tmp_path, "", "A took 48.3 s; B took {{ t | B | v (ours) | .1f }} s")
    bad = untabled_numbers(study, folder, tmp_path / "published")
    assert [b[1] for b in bad] == ["48.3"], bad
    # the table note the code writes may still state any cell of the study
    study, folder = _built(tmp_path / "b", "A took 48.3 s", "B took {{ t | B | v (ours) | .1f }} s")
    assert untabled_numbers(study, folder, tmp_path / "published") == []


def test_claims_reasons_are_checked_in_the_study_file_with_their_placeholders_bound(tmp_path):
    study, folder = _built(tmp_path, "", "")
    study.doc["claims"] = [{"claim": "x", "table": "t", "key": "method", "ours": "v (ours)", "check": {"max": "B"},
                            "reason": "ours {{ t | A | v (ours) | .1f }}, typed 48.3",
                            "readings": [{"label": "other", "reason": "also 12346"}]}]
    assert [b[1] for b in untabled_numbers(study, folder, tmp_path / "published")] == ["48.3", "12346"]


def test_check_prose_verb_fails_on_a_typed_result(tmp_path, capsys):
    """The build's check_prose rule: exit 0 when every number is bound, 2 (one error line) when a study
    file's reason types a result by hand."""
    from pipeline.cli import main
    from tests.conftest import DATA

    (tmp_path / "built" / "tables").mkdir(parents=True)
    assert main(["check_prose", "--study", str(DATA / "studies" / "mariano2019.yaml"),
                 "--built", str(tmp_path / "built"), "--published", str(DATA / "published")]) == 0
    text = (DATA / "studies" / "mariano2019.yaml").read_text()
    bad = text.replace("the same closed form (", "the same closed form (typed 123.4; ", 1)
    assert bad != text
    (tmp_path / "mariano2019.yaml").write_text(bad)
    assert main(["check_prose", "--study", str(tmp_path / "mariano2019.yaml"), "--built", str(tmp_path / "built"),
                 "--published", str(DATA / "published")]) == 2
    out, err = capsys.readouterr()
    assert "'123.4'" in out and err.count("\n") == 1 and "number(s) in the prose bound to no cell" in err


def test_a_bound_note_is_written_filled_and_checked_as_its_template(tmp_path):
    """A table note the code writes bound (TableSpec.bound): write_tables fills its placeholders from the
    cells they name and keeps the template; the prose check reads the template, so a number of ours typed
    into it fails even where some cell holds it, and a document fact passes."""
    from pipeline.studies import TableSpec, write_tables

    note = "B took {{ t | B | v (ours) | .1f }} s, A 48.3 s; cap 500, published 7 322"
    write_tables([TableSpec("t", "T", T["t"], note, bound=True)], tmp_path / "s" / "tables")
    entry = json.loads((tmp_path / "s" / "tables" / "index.json").read_text())[0]
    assert entry["note"] == "B took 12345.6 s, A 48.3 s; cap 500, published 7 322" and entry["note_bound"] == note
    study = SimpleNamespace(id="s", doc={"solvers": {"a": {"max_iterations": 500}}, "prose_facts": [7322]})
    assert [b[1] for b in untabled_numbers(study, tmp_path / "s", tmp_path / "published")] == ["48.3"]
    # the same note written free (the default) is held by any cell of the study
    write_tables([TableSpec("t", "T", T["t"], "A 48.3 s")], tmp_path / "f" / "tables")
    assert untabled_numbers(study, tmp_path / "f", tmp_path / "published") == []
