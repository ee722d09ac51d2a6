"""Claim kinds, rule sources and values near a threshold: what REPRODUCTION.md counts, where
a threshold comes from, and enough digits to tell a ratio of 1.002 from 1."""

import json

import pytest
from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.results.check import compare_doc
from vehicle_observers.results.pipeline import tally, write_reproduction
from vehicle_observers.results.reporting import Report
from vehicle_observers.results.rules import KINDS, Rule, RuleError, distinguishing_digits


def _claim(rep, item, metric, rule, kind="paper"):
    return rep.claim("P", item, "", metric, rule, kind=kind)


def test_claim_kind_is_stored_default_paper_and_checked(tmp_path):
    rep = Report("99_kinds", tmp_path, show=False)
    rep.metric("r", 0.5)
    _claim(rep, "a", "r", Rule("r", reproduced="value <= 1", source="paper: (1)"))
    _claim(rep, "b", "r", Rule("r", reproduced="value <= 1", source="chosen here: x"), kind="target")
    rep.record(claims=[dict(paper="P", item="c", figure="", metric="r", kind="diagnostic",
                            rule=Rule("r", reproduced="value < 0.1", source="paper: (2)"))])
    with pytest.raises(ObserverArgumentError, match="kind must be one of paper, target"):
        _claim(rep, "d", "r", Rule("r", reproduced="value <= 1"), kind="theory")
    rep.write()
    doc = json.loads(rep.metrics_path.read_text())
    assert [c["kind"] for c in doc["claims"]] == ["paper", "target", "diagnostic"]
    assert [c["verdict"] for c in doc["claims"]] == ["reproduced", "reproduced", "differs"]
    assert doc["claims"][1]["rule_def"]["source"] == "chosen here: x"
    assert set(KINDS) == {"paper", "target", "diagnostic", "baseline", "data"}


def test_rule_source_must_say_paper_or_chosen_here():
    assert Rule("a", reproduced="value < 1", source="paper: eq. (34)").source == "paper: eq. (34)"
    Rule("a", reproduced="value < 1", source="chosen here: 2 % of the amplitude")
    Rule("a", reproduced="value < 1", source="paper: 'short'; chosen here: 2 s")
    with pytest.raises(RuleError, match="source must start with 'paper:' or 'chosen here:'"):
        Rule("a", reproduced="value < 1", source="because it looks right")
    assert Rule.no_number("a", paper="not printed").source == ""


def test_check_fails_on_a_changed_kind():
    def doc(kind):
        return {"notebook": "99_x", "metrics": {},
                "claims": [{"paper": "P", "item": "i", "verdict": "differs", "kind": kind}]}
    dr = compare_doc(doc("paper"), doc("diagnostic"))
    assert len(dr) == 1 and not dr[0].ok and dr[0].what.startswith("claim kind")
    assert (dr[0].committed, dr[0].regenerated) == ("paper", "diagnostic")
    assert compare_doc(doc("target"), doc("target")) == []
    old = doc("paper")
    del old["claims"][0]["kind"]  # written before kinds existed: a paper claim
    assert compare_doc(old, doc("paper")) == []


def test_thresholds_are_the_numbers_value_is_compared_with():
    r = Rule("r", reproduced="value <= 1 and other < 5", partly="0.5 * lim > value",
             informative="abs(value - 2) < 1")
    assert r.thresholds({"r": 1.002, "other": 0.0, "lim": 3.0}) == [1.0, 1.5]
    assert Rule.no_number("r", paper="x").thresholds({"r": 1.0}) == []


@pytest.mark.parametrize("value, thresholds, digits, expected", [
    (1.002, [1.0], 3, 4),        # "1" would hide the tie: "1.002"
    (0.99996, [1.0], 3, 5),      # "1" would even cross the threshold: "0.99996"
    (1.1386, [0.9, 1.0], 3, 3),  # far enough: "1.14"
    (1.0, [1.0], 3, 3),          # equal to the threshold: nothing to tell apart
    (12, [10], 3, 3),            # integers are exact
    ([1.002, 2.0], [1.0], 3, 3),  # vectors keep the rule's digits
])
def test_distinguishing_digits(value, thresholds, digits, expected):
    assert distinguishing_digits(value, thresholds, digits) == expected


def test_report_stores_enough_digits_to_tell_the_value_from_a_threshold(tmp_path):
    rep = Report("99_tie", tmp_path, show=False)
    rep.metric("a", 1.0000412, digits=8)
    rep.metric("b", 1.0)
    _claim(rep, "tie", "a / b", Rule("a / b", reproduced="value <= 1", source="paper: (1)"))
    rep.write()
    assert json.loads(rep.metrics_path.read_text())["claims"][0]["value"] == 1.00004   # 6 digits, not "1"
    assert rep.claims[0].verdict == "differs"


def _notebook(root, name, claims, paper="P"):
    """A notebook's metrics.json with ``claims`` = [(item, metric value, rule, kind[, duplicate_of])]."""
    rep = Report(name, root, show=False)
    for k, (item, v, rule, kind, *dup) in enumerate(claims):
        rep.metric(f"m{k}", v)
        rep.claim(paper, item, "", f"m{k}", Rule(f"m{k}", **rule), kind=kind,
                  duplicate_of=dup[0] if dup else "")
    rep.write()


def test_a_claim_graded_twice_is_listed_with_its_reference_and_counted_once(tmp_path):
    """Catches padding: the same paper claim graded in two notebooks counted twice in the
    summary, the per-paper tally or the per-notebook tally."""
    le1 = dict(reproduced="value <= 1", source="paper: (7)")
    _notebook(tmp_path, "03_a", [("Theorem 1 enclosure", 0.5, le1, "paper"),
                                 ("Fig. 3 widths", 2.0, le1, "paper")], paper="Ifqir 2017")
    _notebook(tmp_path, "08_b", [("enclosure on another car", 0.7, le1, "paper",
                                  "03_a: Theorem 1 enclosure")], paper="Ifqir 2017 (interval)")
    _notebook(tmp_path, "04_c", [("Fig. 2", 0.1, le1, "paper")], paper="Ichalal 2011; Fig. 2")
    text = write_reproduction(tmp_path, tmp_path / "R.md", tmp_path).read_text()
    summary = next(ln for ln in text.splitlines() if ln.startswith("Summary:"))
    assert summary.startswith("Summary: 3 distinct paper claims: 2 reproduced, 0 partly, 1 differs")
    assert "1 more rows grade a claim already counted" in summary
    table = text.split("## Distinct paper claims per paper\n\n")[1].split("\n\n")[0].splitlines()
    assert table[2:] == ["| Ichalal 2011 | 04 | 1 | 1 | 0 | 0 | 0 |",
                         "| Ifqir 2017 | 03, 08 | 2 | 1 | 0 | 1 | 0 |"]
    assert "- 08_b: 0 (none) [1 duplicate]" in text
    row = next(ln for ln in text.splitlines() if "| enclosure on another car |" in ln)
    assert "**reproduced** (duplicate, not counted)" in row
    assert "  - same claim as [p03.1] (03_a: Theorem 1 enclosure): listed, not counted again" in text
    assert "Paper claims: 3 paper claims" not in text and "3 paper claims: 2 reproduced" in text


def test_reproduction_counts_paper_claims_apart_from_the_other_kinds(tmp_path):
    le1 = dict(reproduced="value <= 1", source="paper: the bound (34)")
    _notebook(tmp_path, "01_a", [
        ("bound", 0.01, {**le1, "informative": "value >= 0.1"}, "paper"),
        ("fit", 0.97, dict(reproduced="value >= 0.98", partly="value >= 0.95",
                           source="chosen here: no number printed"), "paper"),
        ("data check", 0.101, dict(reproduced="abs(value - 0.10) <= 0.01",
                                   source="chosen here: provenance value"), "data")])
    _notebook(tmp_path, "02_b", [
        ("gains", 2.0, le1, "paper"),
        ("smoother", 1.002, dict(reproduced="value <= 1", source="paper: RTS 1965"), "diagnostic"),
        ("white", 0.0, dict(reproduced="value >= 0.01", source="paper: Mehra 1970"), "diagnostic"),
        ("target", 0.2143, dict(reproduced="value <= 0.24", source="chosen here: a target"), "target")])
    text = write_reproduction(tmp_path, tmp_path / "R.md", tmp_path).read_text()
    summary = next(ln for ln in text.splitlines() if ln.startswith("Summary:"))
    assert summary == (
        "Summary: 3 distinct paper claims: 1 reproduced (1 of which hold but prove little), 1 partly, "
        "1 differs, 0 not comparable. Counted apart, not paper claims: 1 benchmark target "
        "(1 reproduced); 2 diagnostics (2 differs); 1 data check (1 reproduced).")
    heads = [ln for ln in text.splitlines() if ln.startswith("## ")]
    assert heads == ["## Distinct paper claims per paper", "## Paper claims", "## Benchmark targets",
                     "## Diagnostics", "## Data checks",
                     "## 01_a", "## 02_b"]
    paper = text.split("\n## Paper claims\n")[1].split("\n## Benchmark targets\n")[0]
    assert "smoother" not in paper and "data check" not in paper and "| fit |" in paper
    row = next(ln for ln in text.splitlines() if ln.startswith("| P | smoother |"))
    assert "| 1.002 |" in row and row.endswith("| [d02.1] |")   # tie shown; details below
    assert "  - threshold from: paper: RTS 1965" in text.split("- [d02.1] rule:")[1].splitlines()[1]
    assert "| 0.214 |" in next(ln for ln in text.splitlines() if "| target |" in ln)
    assert "claims: 2 paper claims, 1 data check." in text


def test_tally_counts_every_verdict_or_only_those_present():
    cs = [{"verdict": "reproduced", "proves_little": True}, {"verdict": "differs"}]
    assert tally(cs) == ("1 reproduced (1 of which hold but prove little), 0 partly, 1 differs, "
                         "0 not comparable")
    assert tally(cs, zeros=False) == "1 reproduced (1 of which hold but prove little), 1 differs"
