"""Claims of a document checked on a study's tables (pipeline.studies.claims): computed verdicts."""

from __future__ import annotations

from types import SimpleNamespace

import pandas as pd
import pytest
from hypothesis import given
from hypothesis import strategies as st

from pipeline.settings import load_study
from pipeline.studies import TableSpec
from pipeline.studies.claims import DIFFERS, HOLDS, MISSING, claims_table, evaluate, with_claims
from tests.conftest import DATA

FRAME = pd.DataFrame({"method": ["A", "B", "C"], "x (ours)": [1.0, 3.0, 2.0], "x (published)": [1.0, 2.0, 3.0]})


@pytest.mark.parametrize("check,verdict", [
    ({"max": "B"}, HOLDS), ({"max": "C"}, DIFFERS), ({"min": "A"}, HOLDS),
    ({"order": ["A", "C", "B"]}, HOLDS), ({"order": ["A", "B", "C"]}, DIFFERS),
    ({"less": ["A", "B"]}, HOLDS), ({"less": ["B", "C"]}, DIFFERS),
    ({"ratio_at_least": ["B", "A", 3]}, HOLDS), ({"ratio_at_least": ["B", "A", 3.5]}, DIFFERS),
    ({"max": "Z"}, MISSING), ({"less": ["A", "Z"]}, MISSING),
])
def test_checks(check, verdict):
    assert evaluate(check, FRAME, "method", "x (ours)")[0] == verdict


def test_within_compares_ours_with_published():
    assert evaluate({"within": {"row": "B", "rel": 0.5}}, FRAME, "method", "x (ours)", "x (published)")[0] == HOLDS
    assert evaluate({"within": {"row": "B", "rel": 0.4}}, FRAME, "method", "x (ours)", "x (published)")[0] == DIFFERS
    assert evaluate({"within": {"row": "B", "rel": 0.4}}, FRAME, "method", "x (ours)")[0] == MISSING


def test_row_filter_absolute_bound_and_two_columns_of_one_row():
    from pipeline.studies.claims import evaluate_claim, select

    f = pd.DataFrame({"method": ["A", "A", "B", "B"], "statistic": ["mean", "max", "mean", "max"],
                      "t (ours)": [1.0, 9.0, 2.0, 3.0], "t (published)": [5.0, 6.0, 4.0, 7.0],
                      "u (ours)": [2.0, 0.0, 1.0, 0.0], "u (published)": [6.0, 0.0, 3.0, 0.0]})
    means = select(f, {"statistic": "mean"})
    assert list(means["method"]) == ["A", "B"] and select(f, {"nope": 1}) is None
    claim = {"key": "method", "ours": "t (ours)", "published": "t (published)", "check": {"min": "A"}}
    assert evaluate_claim(claim, means)[::2] == (HOLDS, DIFFERS)
    assert evaluate({"abs_at_most": 2.0}, means, "method", "t (ours)")[0] == HOLDS
    assert evaluate({"abs_at_most": 1.5}, means, "method", "t (ours)")[0] == DIFFERS
    two = {"key": "method", "ours": "t (ours)", "published": "t (published)",
           "check": {"column_less": {"row": "A", "than": "u (ours)", "than_published": "u (published)"}}}
    assert evaluate_claim(two, means)[::2] == (HOLDS, HOLDS)
    two["check"]["column_less"]["row"] = "B"
    assert evaluate_claim(two, means)[::2] == (DIFFERS, DIFFERS)


def test_a_missing_table_or_column_or_nan_is_not_reproduced():
    assert evaluate({"max": "A"}, None, "method", "x (ours)")[0] == MISSING
    assert evaluate({"max": "A"}, FRAME, "method", "y (ours)")[0] == MISSING
    nan = FRAME.assign(**{"x (ours)": [1.0, float("nan"), 2.0]})
    assert evaluate({"less": ["A", "B"]}, nan, "method", "x (ours)")[0] == MISSING


@given(st.lists(st.floats(-1e6, 1e6, allow_nan=False), min_size=2, max_size=6, unique=True))
def test_max_and_min_agree_with_pandas(values):
    f = pd.DataFrame({"k": [f"r{i}" for i in range(len(values))], "v": values})
    top, low = f.loc[f["v"].idxmax(), "k"], f.loc[f["v"].idxmin(), "k"]
    assert evaluate({"max": top}, f, "k", "v")[0] == HOLDS
    assert evaluate({"min": low}, f, "k", "v")[0] == HOLDS
    assert evaluate({"max": low}, f, "k", "v")[0] == DIFFERS


def test_claims_table_comes_first_and_computes_both_verdicts():
    study = SimpleNamespace(doc={
        "claims": [{"claim": "B largest", "table": "t", "key": "method", "ours": "x (ours)",
                    "published": "x (published)", "check": {"max": "B"}, "reason": "because"},
                   {"claim": "C largest", "table": "t", "key": "method", "ours": "x (ours)",
                    "published": "x (published)", "check": {"max": "C"}, "reason": "ours differs"},
                   {"claim": "in another table", "table": "absent", "key": "method", "ours": "x (ours)",
                    "check": {"min": "A"}}],
        "not_reproduced": [{"item": "Table 9", "why": "no data"}]})
    tables = with_claims(study, [TableSpec("t", "T", FRAME)])
    assert [t.name for t in tables] == ["claims", "not_reproduced", "t"]
    c = tables[0].frame
    assert list(c["verdict (ours)"]) == [HOLDS, DIFFERS, MISSING]
    assert list(c["verdict (published numbers)"]) == [DIFFERS, HOLDS, "—"]
    assert list(c["why"]) == ["", "ours differs", ""]


def test_without_claims_nothing_is_added():
    study = SimpleNamespace(doc={})
    assert claims_table(study, []) is None and with_claims(study, []) == []


@pytest.mark.parametrize("sid", ["cerbaro2019", "erthal1992", "borges_kr6", "mariano2019", "nepomuceno2024"])
def test_every_document_study_lists_its_claims_and_what_it_leaves_out(sid):
    doc = load_study(DATA / "studies" / f"{sid}.yaml").doc
    assert len(doc.get("claims", [])) >= 3, "each document study checks its headline claims"
    assert doc.get("not_reproduced"), "each document study lists what it does not reproduce"


# ---- checks added for claims that face every headline (issue 27) ------------------------------------

TWO = pd.DataFrame({"point": [1, 2, 3, 4], "a (ours)": [10.0, 0.0, 5.0, 7.0], "b (ours)": [9.0, 1.0, 5.0, 7.5],
                    "c (ours)": [1.0, 2.0, 4.0, 0.0], "ok (ours)": [1, 1, 0, 1]})


@pytest.mark.parametrize("check,verdict", [
    ({"at_most": {"row": "1", "value": 10}}, HOLDS), ({"at_most": {"row": "1", "value": 9.9}}, DIFFERS),
    ({"at_least": {"row": "4", "value": 7}}, HOLDS), ({"at_least": {"row": "4", "value": 7.1}}, DIFFERS),
    ({"all_at_least": 0}, HOLDS), ({"all_at_least": 0.1}, DIFFERS),
    ({"same_as": {"rows": ["3"], "than": "b (ours)"}}, HOLDS),
    ({"same_as": {"rows": ["3", "4"], "than": "b (ours)"}}, DIFFERS),
    ({"same_as": {"rows": ["3", "4"], "than": "b (ours)", "tol": 0.5}}, HOLDS),
    ({"column_largest": {"of": ["c (ours)"]}}, DIFFERS),  # point 2: 0 < 2
    ({"at_most": {"row": "9", "value": 1}}, MISSING), ({"same_as": {"rows": ["1"], "than": "zz"}}, MISSING),
])
def test_new_checks(check, verdict):
    assert evaluate(check, TWO, "point", "a (ours)")[0] == verdict


def test_column_largest_and_nonzero_exactly():
    f = TWO[TWO["point"] != 2]
    assert evaluate({"column_largest": {"of": ["c (ours)"]}}, f, "point", "a (ours)")[0] == HOLDS
    assert evaluate({"column_largest": {"of": ["c (ours)", "b (ours)"]}}, f, "point", "a (ours)")[0] == DIFFERS
    assert evaluate({"nonzero_exactly": ["1", "2", "4"]}, TWO, "point", "ok (ours)")[0] == HOLDS
    assert evaluate({"nonzero_exactly": ["1", "2"]}, TWO, "point", "ok (ours)")[0] == DIFFERS
    # whole numbers name the same row whether the frame holds 1 or 1.0 (a CSV against the built frame)
    g = TWO.assign(point=TWO["point"].astype(float))
    assert evaluate({"nonzero_exactly": ["1", "2", "4"]}, g, "point", "ok (ours)")[0] == HOLDS
    assert evaluate({"at_most": {"row": "1", "value": 10}}, g, "point", "a (ours)")[0] == HOLDS


def test_rows_select_numbers_as_numbers_and_lists_as_any_of():
    from pipeline.studies.claims import select

    f = pd.DataFrame({"d [mm]": [300.0, 960.0, 960.0], "m": ["X", "Y", "Z"], "v": [1, 2, 3]})
    assert list(select(f, {"d [mm]": 960})["m"]) == ["Y", "Z"]
    assert list(select(f, {"m": ["X", "Z"]})["v"]) == [1, 3]


def test_every_reading_has_a_row_and_only_the_headline_counts():
    from pipeline.studies.claims import NOT_COMPARABLE, count_line

    study = SimpleNamespace(path="s.yaml", doc={"claims": [
        {"claim": "B largest", "table": "t", "key": "method", "ours": "x (ours)", "published": "x (published)",
         "check": {"max": "B"}, "reading": "ours", "reason": "never shown",
         "readings": [{"label": "on the published column", "ours": "x (published)", "reason": "C is larger there"}]},
        {"claim": "A smallest", "table": "t", "key": "method", "ours": "x (ours)", "check": {"min": "A"},
         "not_comparable": "different platforms"},
        {"claim": "C largest", "table": "t", "key": "method", "ours": "x (ours)", "check": {"max": "C"},
         "reason": "B is {{ t | B | x (ours) | .1f }}"}]})
    t = claims_table(study, [TableSpec("t", "T", FRAME)]).frame
    assert list(t["counts"]) == ["yes", "no (shown beside)", "yes", "yes"]
    assert list(t["verdict (ours)"]) == [HOLDS, DIFFERS, NOT_COMPARABLE, DIFFERS]
    assert list(t["why"]) == ["", "C is larger there", "different platforms", "B is 3.0"]
    assert count_line([HOLDS, NOT_COMPARABLE, DIFFERS]) == "1 of 3 claims hold (1 differs, 1 not comparable here)"
    assert claims_table(study, [TableSpec("t", "T", FRAME)]).note.startswith("1 of 3 claims hold")


def test_a_placeholder_naming_an_unknown_column_is_one_line_naming_the_study_file():
    from pipeline.errors import UsageError

    study = SimpleNamespace(path="data/studies/x.yaml", doc={"claims": [
        {"claim": "C largest", "table": "t", "key": "method", "ours": "x (ours)", "check": {"max": "C"},
         "reason": "B is {{ t | B | no such column }}"}]})
    with pytest.raises(UsageError, match=r"^data/studies/x.yaml: field 'claims/0': placeholder .*no column 'no such column'"):
        claims_table(study, [TableSpec("t", "T", FRAME)])


# ---- verdicts added in issue 45: ties, claims that cannot fail, headlines no table decides -------------

def test_ties_cannot_fail_not_reproducible_and_unmeasured_reasons():
    from pipeline.studies.claims import CANNOT_FAIL, NOT_MEASURED, NOT_REPRODUCIBLE, TIE, count_line

    close = pd.DataFrame({"method": ["A", "B", "C"], "x (ours)": [1.0, 1.004, 0.5]})
    base = {"table": "t", "key": "method", "ours": "x (ours)"}
    study = SimpleNamespace(path="s.yaml", doc={"claims": [
        {"claim": "A largest", **base, "check": {"max": "A"}, "tie_within": 0.01, "reason": "B by a hair"},
        {"claim": "B largest", **base, "check": {"max": "B"}, "tie_within": 0.001},
        {"claim": "C below A", **base, "check": {"less": ["C", "A"]}, "cannot_fail": "by construction"},
        {"claim": "not decidable", "not_reproducible": "no table measures it"},
        {"claim": "in a table this build lacks", "table": "absent", "key": "method", "ours": "x (ours)",
         "check": {"min": "A"}, "reason": "ours is {{ absent | A | x }}"}]})
    t = claims_table(study, [TableSpec("t", "T", close)]).frame
    assert list(t["verdict (ours)"]) == [TIE, HOLDS, CANNOT_FAIL, NOT_REPRODUCIBLE, MISSING]
    assert list(t["why"]) == ["B by a hair", "", "by construction", "no table measures it", NOT_MEASURED]
    assert count_line(list(t["verdict (ours)"])) == (
        "1 of 5 claims hold (1 tie, 1 cannot fail here, 1 not reproducible here, 1 not reproduced)")


def test_close_check():
    assert evaluate({"close": {"rows": ["B", "C"], "rel": 0.34}}, FRAME, "method", "x (ours)")[0] == HOLDS
    assert evaluate({"close": {"rows": ["B", "C"], "rel": 0.3}}, FRAME, "method", "x (ours)")[0] == DIFFERS
    assert evaluate({"close": {"rows": ["B", "Z"], "rel": 0.3}}, FRAME, "method", "x (ours)")[0] == MISSING


@pytest.mark.parametrize("check,verdict", [
    # a (ours): 10, 0, 5, 7 -- point 1 is the largest by 10/7, point 2 the smallest by any factor
    ({"max_by": {"row": "1", "factor": 1.4}}, HOLDS), ({"max_by": {"row": "1", "factor": 1.5}}, DIFFERS),
    ({"max": "1"}, HOLDS),  # the bare order passes on any margin: the degree needs max_by
    ({"max_by": {"row": "4", "factor": 1}}, DIFFERS),  # not the largest at all
    ({"min_by": {"row": "2", "factor": 100}}, HOLDS), ({"min_by": {"row": "3", "factor": 1}}, DIFFERS),
    ({"max_by": {"row": "9", "factor": 2}}, MISSING),
])
def test_degree_checks_need_the_margin_not_only_the_order(check, verdict):
    """``max_by``/``min_by`` read "by far the most / the fewest" on the factor to the nearest rival."""
    assert evaluate(check, TWO, "point", "a (ours)")[0] == verdict


DOCUMENT_STUDIES = ["cerbaro2019", "erthal1992", "borges_kr6", "mariano2019", "nepomuceno2024"]


@pytest.mark.parametrize("sid", DOCUMENT_STUDIES)
def test_the_headline_map_names_every_claim_and_counts_them_as_the_study_file_does(sid):
    """data/claims_headline_map.md maps each headline sentence of the document to a claim (cN = the N-th
    entry of the study file's claims): every cN it names exists, every claim is named, and its count
    table gives the study file's number of claims and of not-reproducible ones (a reader can recount)."""
    import re

    claims = load_study(DATA / "studies" / f"{sid}.yaml").doc["claims"]
    text = (DATA / "claims_headline_map.md").read_text()
    section = re.search(rf"^## {sid} .*?(?=^## |\Z)", text, re.M | re.S).group(0)
    named = {int(n) for n in re.findall(r"\bc(\d+)\b", section)}
    assert named == set(range(1, len(claims) + 1)), sorted(named ^ set(range(1, len(claims) + 1)))
    nr = {int(n) for n in re.findall(r"\bc(\d+) NR\b", section)}
    assert nr == {k + 1 for k, c in enumerate(claims) if c.get("not_reproducible")}
    index = dict(re.findall(r"^- c(\d+): (.*?)(?: …)?$", section, re.M))  # each claim's opening words, in order
    assert sorted(map(int, index)) == list(range(1, len(claims) + 1))
    for n, opening in index.items():  # a claim inserted or moved shifts the cN: the openings no longer match
        assert claims[int(n) - 1]["claim"].startswith(opening), (n, opening)
    row = re.search(rf"^\| {sid} \| (\d+) \| (\d+) \| (\d+) \| (\d+) \|$", text, re.M)
    assert row and (int(row.group(2)), int(row.group(3)), int(row.group(4))) == (len(claims), len(nr), len(claims))
