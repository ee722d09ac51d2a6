"""Rules turn metrics into verdicts; the Report records claims only through them."""

import json

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402
from vehicle_observers.results.reporting import Report, load_metrics  # noqa: E402
from vehicle_observers.results.rules import Rule, RuleError, evaluate, fmt, round_sig  # noqa: E402
from vehicle_observers.results.tables import Table, metric_table  # noqa: E402


def test_verdict_follows_the_metric_both_ways():
    r = Rule("ratio", reproduced="value <= 1", partly="value <= 2", paper="error below bound")
    assert r.judge({"ratio": 0.5}).verdict == "reproduced"
    assert r.judge({"ratio": 1.5}).verdict == "partly"
    assert r.judge({"ratio": 2.5}).verdict == "differs"
    assert Rule("ratio", reproduced="value <= 1").judge({"ratio": 1.5}).verdict == "differs"


def test_no_number_is_not_comparable_and_still_evaluates_the_value():
    j = Rule.no_number("a / b", paper="not printed").judge({"a": 3.0, "b": 2.0})
    assert (j.verdict, j.value) == ("not comparable", 1.5)


def test_informative_condition_flags_a_check_that_proves_little():
    r = Rule("ratio", reproduced="value <= 1", informative="value >= 0.1")
    assert r.judge({"ratio": 0.007}).proves_little
    assert not r.judge({"ratio": 0.5}).proves_little
    assert r.judge({"ratio": 0.007}).verdict == "reproduced"


def test_expressions_over_vectors_and_other_metrics():
    m = {"a": [1.0, 2.0, 4.0], "b": [2.0, 2.0, 2.0], "lim": 2.5}
    assert evaluate("a[2] / b[2]", m) == 2.0
    assert evaluate("max(a)", m) == 4.0
    assert Rule("a[2] / b[2]", reproduced="value < lim").judge(m).verdict == "reproduced"
    assert Rule("abs(a[0] - 1.1)", reproduced="value <= 0.05").judge(m).verdict == "differs"


@pytest.mark.parametrize("expr, msg", [
    ("missing_metric + 1", "no metric named missing_metric"),
    ("__import__('os')", "only"),
    ("a.real", "Attribute is not allowed"),
    ("a +", "rule expression"),
])
def test_bad_rules_are_refused_with_a_clear_message(expr, msg):
    with pytest.raises(RuleError, match=msg):
        Rule(expr).judge({"a": 1.0}) if "missing" in expr else Rule(expr)


def test_metric_names_that_are_not_identifiers():
    m = {"revs.ekf.rmse_vy": 0.229, "revs.rts.rmse_vy": 0.304}
    r = Rule("metric('revs.rts.rmse_vy') / metric('revs.ekf.rmse_vy')", reproduced="value <= 1")
    j = r.judge(m)
    assert j.verdict == "differs" and abs(j.value - 0.304 / 0.229) < 1e-12
    with pytest.raises(RuleError, match="no metric named revs.ukf"):
        Rule("metric('revs.ukf.rmse_vy')").judge(m)


def test_condition_must_be_boolean_and_value_finite():
    with pytest.raises(RuleError, match="True/False"):
        Rule("a", reproduced="value + 1").judge({"a": 1.0})
    with pytest.raises(RuleError, match="not finite"):
        Rule("a / b", reproduced="value < 1").judge({"a": 1.0, "b": 0.0})
    with pytest.raises(RuleError, match="not finite"):
        Rule("a", reproduced="value < 1").judge({"a": float("nan")})


def test_rule_text_shows_every_condition():
    t = Rule("x", reproduced="value <= 1", partly="value <= 2", informative="value > 0.1").text()
    assert "`x`" in t and "`value <= 1`" in t and "partly if `value <= 2`" in t
    assert "informative if `value > 0.1`" in t


def test_rounding_and_formatting():
    assert round_sig(83.71880457924199, 4) == 83.72
    assert round_sig([0.0026712486041248003, 18.88387764745261], 3) == [0.00267, 18.9]
    assert round_sig({"a": 1.23456, "b": [2.34567]}, 3) == {"a": 1.23, "b": [2.35]}
    assert round_sig(True, 3) is True and round_sig(55001, 3) == 55001
    assert fmt(0.007076869442409314) == "0.00708"
    assert fmt(list(range(20))) == "20 values in [0, 19]"
    assert fmt([1.23456, 2.0]) == "[1.23, 2]"
    assert fmt({"a": 1.23456}) == "{a: 1.23}"
    assert fmt({f"k{i}": [1.0] * 5 for i in range(20)}) == "table of 20 entries (metrics.json)"
    assert fmt(["x" * 20] * 20) == "20 entries (metrics.json)"


def test_report_computes_stores_and_writes(tmp_path):
    rep = Report("99_test", tmp_path, show=False)
    stored = rep.metric("ratio", 0.0070768694, "")
    assert stored == 0.007077
    rep.metric("lmi_c", 0.0254287, "", rtol=0.01, why="solver accuracy")
    with pytest.raises(ValueError, match="why"):
        rep.metric("x", 1.0, rtol=0.1)
    j = rep.claim("P", "Bound", "", "max ratio",
                  Rule("ratio", reproduced="value <= 1", paper="below bound", informative="value > 0.1"))
    assert j.verdict == "reproduced" and j.proves_little
    rep.timing("solve_s", 0.123)
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    assert rep.savefig(fig, "fig") is None
    assert rep.write() is None
    path = rep.metrics_path
    doc = json.loads(path.read_text())
    c = doc["claims"][0]
    assert c["verdict"] == "reproduced" and c["proves_little"] and "value <= 1" in c["rule"]
    assert "solve_s" not in doc["metrics"]
    assert doc["metrics"]["lmi_c"]["rtol"] == 0.01
    assert sorted(doc["files"]) == ["fig.pdf", "fig.png", "figure_data.json", "metrics.json"]
    assert load_metrics(path)["ratio"] == 0.007077


def test_report_claim_takes_no_handwritten_verdict(tmp_path):
    rep = Report("99_test", tmp_path, show=False)
    rep.metric("a", 1.0)
    with pytest.raises(TypeError, match="unexpected keyword argument 'verdict'"):
        rep.claim("P", "i", "", "m", Rule("a", reproduced="value < 2"), verdict="differs")
    with pytest.raises(TypeError, match="rule must be a Rule"):
        rep.claim("P", "i", "", "m", 1.0)


def test_default_output_is_the_ignored_interactive_folder():
    from vehicle_observers.data.logs import repo_root

    rep = Report("99_interactive_probe", show=False)
    assert rep.dir == repo_root() / "build" / "interactive" / "99_interactive_probe"
    rep.dir.rmdir()


def test_tables_round_and_render():
    t = Table([{"name": "ekf", "rmse": 0.229123456}, {"name": "rts", "rmse": 0.30412}], digits=3)
    assert "0.229" in t._repr_html_() and "0.229123" not in t._repr_html_()
    assert "0.304" in repr(t)
    mt = metric_table({"a": 1.23456, "b": [1, 2]}, digits=2)
    assert "1.2" in repr(mt) and "[1, 2]" in repr(mt)


def test_not_comparable_needs_its_reason_and_says_it():
    from vehicle_observers.results.rules import Rule, RuleError

    r = Rule.not_comparable("x", paper="x = 1", because="the reconstruction fixes x")
    assert r.judge({"x": 0.3}).verdict == "not comparable"
    assert "not comparable: the reconstruction fixes x" in r.text()
    with pytest.raises(RuleError, match="because"):
        Rule.not_comparable("x", paper="x = 1", because="")
