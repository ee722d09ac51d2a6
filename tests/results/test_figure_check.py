"""The regeneration check compares what every figure shows (``figure_data.json``), not only the
metrics: a planted colour change, a lost series or moved data fail it; re-rendering the same
figure does not."""

from __future__ import annotations

import json

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from vehicle_observers.results import check  # noqa: E402
from vehicle_observers.results.plotting import figure_data  # noqa: E402
from vehicle_observers.results.reporting import Report  # noqa: E402


def _bars(colour="k", hatch="//", heights=(0.0575, 0.283), title="RMSE 0.0575 m/s", shift=0.0,
          series=2):
    fig, (a, b) = plt.subplots(1, 2)
    a.bar([0, 1], heights, color=["tab:blue", colour], hatch=hatch)
    a.set_title(title)
    a.set_ylabel("$v_y$ RMSE [m/s]")
    t = np.linspace(0.0, 10.0, 201)
    for k in range(series):
        b.plot(t, np.sin(t + k) + shift, label=f"s{k}")
    b.set_xlabel("time [s]")
    b.legend()
    d = json.loads(json.dumps(figure_data(fig)))
    plt.close(fig)
    return d


def _drifts(**planted):
    return check.compare_figure_data("00_x", {"f": _bars()}, {"f": _bars(**planted)})


def test_the_same_figure_drawn_again_shows_no_drift():
    """Catches a check that fails on rendering alone (the figure data must be reproducible)."""
    assert _drifts() == []


@pytest.mark.parametrize("planted, where", [
    (dict(colour="#a6c8ff"), "bars.facecolors"),          # the open-loop bar in another colour
    (dict(hatch=None), "bars.hatches"),                    # the 'no feedback' hatch lost
    (dict(series=1), "lines (count)"),                     # a series no longer drawn
    (dict(shift=0.05), "lines[0].y"),                      # data moved by 2.5 % of the axis
    (dict(heights=(0.0575, 0.35)), "bars.height"),         # a bar 24 % taller
    (dict(title="RMSE 0.0575 km/h"), "title"),             # a unit changed in a title
])
def test_a_planted_change_of_what_the_figure_shows_is_a_drift(planted, where):
    """Catches the regeneration check passing while a committed figure differs from what the
    code now draws (e.g. a bar drawn black in a fresh run and light blue in the committed file)."""
    drifts = _drifts(**planted)
    assert drifts and all(not d.ok for d in drifts)
    assert any(where in d.what for d in drifts), [d.what for d in drifts]


def test_tolerances_are_below_what_a_reader_sees():
    """Catches tolerances so wide they hide a visible change, or so tight that round-off fails
    the check: 0.1 % of the axis span and the last printed digit of a title pass."""
    assert _drifts(shift=0.002) == []                      # 0.1 % of the y span
    assert _drifts(title="RMSE 0.0576 m/s") == []          # last printed digit
    assert _drifts(title="RMSE 0.0600 m/s") != []          # 4 % off


def test_make_check_fails_on_a_planted_colour_change(tmp_path, capsys):
    """End to end through the command (``make check`` compares with ``--compare``): two
    folders written by :class:`Report`, one with the open-loop bar's colour changed, exit 1
    naming the figure; identical folders exit 0."""
    for name, colour in (("committed", "k"), ("same", "k"), ("planted", "#a6c8ff")):
        rep = Report("00_x", tmp_path / name, show=False)
        fig, ax = plt.subplots()
        ax.bar([0, 1], [1.0, 2.0], color=["tab:blue", colour])
        ax.set_ylabel("RMSE [m/s]")
        rep.savefig(fig, "rmse_vy_by_estimator")
        rep.metric("m", 1.0)
        rep.write()
    args = ["--committed", str(tmp_path / "committed"), "--compare"]
    assert check.main(args + [str(tmp_path / "same")]) == 0
    assert check.main(args + [str(tmp_path / "planted")]) == 1
    out = capsys.readouterr().out
    assert "figure rmse_vy_by_estimator.axes[0].bars.facecolors" in out


def test_a_figure_missing_from_the_regeneration_is_a_drift():
    """Catches a figure that the code no longer draws while its committed file stays."""
    d = check.compare_figure_data("00_x", {"f": _bars(), "g": _bars()}, {"f": _bars()})
    assert [x.what for x in d] == ["figure g"] and not d[0].ok
