"""Report.record writes metrics, timings and claims in order; claims judged on the metrics
recorded before them, the same call's included."""

import json

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from vehicle_observers.core.errors import ObserverArgumentError  # noqa: E402
from vehicle_observers.results.reporting import Report, Rule  # noqa: E402


def test_record_metrics_and_timings(tmp_path):
    rep = Report("nb", tmp_path, show=False)
    rep.record(metrics={"a": (1.5, "s", "note a"), "b": (np.arange(2), ""), "c": (0.123456,)},
               timings={"us": (3.0, "us"), "solve": (1.25, "s", "LMI")})
    assert rep.metrics == {"a": {"value": 1.5, "unit": "s", "note": "note a", "digits": 4},
                           "b": {"value": [0, 1], "unit": "", "note": "", "digits": 4},
                           "c": {"value": 0.1235, "unit": "", "note": "", "digits": 4}}
    assert list(rep.metrics) == ["a", "b", "c"]
    assert rep.timings == {"us": {"value": 3.0, "unit": "us", "note": ""},
                           "solve": {"value": 1.25, "unit": "s", "note": "LMI"}}
    assert not set(rep.timings) & set(rep.metrics)      # wall clock never becomes a metric


def test_record_equals_one_call_per_entry(tmp_path):
    metrics = {"ratio": (0.8, "", "x / y"), "limit": (1.0, "")}
    claims = [dict(paper="P", item="it", figure="f", metric="ratio",
                   rule=Rule("ratio / limit", reproduced="value <= 1", paper="<= 1"))]
    a = Report("a", tmp_path / "a", show=False)
    a.record(metrics=metrics, claims=claims)
    b = Report("a", tmp_path / "b", show=False)
    for k, v in metrics.items():
        b.metric(k, *v)
    for c in claims:
        b.claim(**c)
    assert a.metrics == b.metrics
    assert [c.__dict__ for c in a.claims] == [c.__dict__ for c in b.claims]


def test_claims_are_judged_after_the_metrics_of_the_same_call(tmp_path):
    rep = Report("nb", tmp_path, show=False)
    rule = Rule("err", reproduced="value <= 0.1", paper="<= 0.1")
    rep.record(claims=[dict(paper="P", item="small", figure="", metric="err", rule=rule)],
               metrics={"err": (0.05, "m/s")})
    assert rep.claims[0].verdict == "reproduced" and rep.claims[0].value == 0.05
    rep.record(metrics={"err": (0.5, "m/s")},
               claims=[dict(paper="P", item="large", figure="", metric="err", rule=rule)])
    assert rep.claims[1].verdict == "differs"


@pytest.mark.parametrize("bad", [1.0, [1.0, "m"], (), (1.0, "m", "n", 4)])
def test_record_names_a_malformed_entry(tmp_path, bad):
    rep = Report("nb", tmp_path, show=False)
    with pytest.raises(ObserverArgumentError, match=r"metrics\['x'\]"):
        rep.record(metrics={"ok": (1.0, ""), "x": bad})
    with pytest.raises(ObserverArgumentError, match=r"timings\['x'\]"):
        rep.record(timings={"x": bad})
    with pytest.raises(ObserverArgumentError, match="claim"):
        rep.record(claims=[("P", "item")])


def test_record_is_keyword_only(tmp_path):
    rep = Report("nb", tmp_path, show=False)
    with pytest.raises(TypeError):
        rep.record({"a": (1.0, "")})
    assert rep.record() is None and rep.metrics == {} and rep.claims == []


def test_report_records_axis_label_problems_beside_its_figures(tmp_path):
    from vehicle_observers.results.reporting import figure_checks_path

    rep = Report("99_labels", tmp_path, show=False)
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    ax.set_xlabel("$t$ [s]")
    ax.set_ylabel("$v_y$")
    rep.savefig(fig, "fig1")
    rep.write()
    doc = json.loads(figure_checks_path(tmp_path / "99_labels").read_text())
    assert doc["problems"] == {"fig1": ["panel 0: y label '$v_y$' has no unit in brackets"]}
    assert figure_checks_path(tmp_path / "other" / "99_labels") != figure_checks_path(tmp_path / "99_labels")
