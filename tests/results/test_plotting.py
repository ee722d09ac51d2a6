"""The one palette and the shared plot helpers of results.plotting."""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.colors import to_hex  # noqa: E402
from vehicle_observers.results import plotting as P  # noqa: E402


def test_palette_is_the_colour_blind_style_and_the_default_cycle():
    want = ["#006ba4", "#ff800e", "#ababab", "#595959", "#5f9ed1", "#c85200", "#898989",
            "#a2c8ec", "#ffbc79", "#cfcfcf"]          # Tableau colour-blind 10
    assert [c.lower() for c in P.PALETTE] == want
    cycle = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    assert [to_hex(c) for c in cycle] == want
    # "C<n>" colours resolve to the palette, so older "C1"-style references draw the same
    assert [to_hex(f"C{i}") for i in range(10)] == want


def test_every_estimator_colour_comes_from_the_palette_and_differs():
    for name, c in P.COLORS.items():
        assert c in P.PALETTE or c == P.TRUTH, name
    bench = ("ekf", "ekf-filterpy", "ukf", "rts", "ts-yacine2015", "interval-ifqir2017",
             "interval-coordinates", "open-loop-linear")
    assert len({P.color(n) for n in bench}) == len(bench)
    for prefix in ("ichalal2011/", "elyoussfi2020/"):
        mine = [c for n, c in P.COLORS.items() if n.startswith(prefix)]
        assert len(set(mine)) == len(mine), prefix


def test_unlisted_names_cycle_through_the_last_four_colours():
    got = [P.color("not-registered", j) for j in range(6)]
    assert got == [P.PALETTE[6], P.PALETTE[7], P.PALETTE[8], P.PALETTE[9], P.PALETTE[6],
                   P.PALETTE[7]]
    assert P.color("ekf", 3) == P.COLORS["ekf"]


def test_grouped_bars_positions_heights_and_colours():
    values = {("a", "ekf"): 1.0, ("a", "mine"): 2.0, ("b", "ekf"): np.nan, ("b", "mine"): 4.0}
    fig, ax = plt.subplots()
    w = P.grouped_bars(ax, ["a", "b"], ["ekf", "mine"], lambda g, s: values.get((g, s)),
                       log=True)
    assert w == pytest.approx(0.4)
    bars = [(p.get_x() + p.get_width() / 2, p.get_height(), to_hex(p.get_facecolor()))
            for p in ax.patches]
    # the NaN bar is left out; bar j of group i is centred at i + j w
    assert bars == [(pytest.approx(0.0), 1.0, P.COLORS["ekf"].lower()),
                    (pytest.approx(0.4), 2.0, P.PALETTE[7].lower()),
                    (pytest.approx(1.4), 4.0, P.PALETTE[7].lower())]
    assert ax.get_yscale() == "log"
    assert [t.get_text() for t in ax.get_xticklabels()] == ["a", "b"]
    assert ax.get_xticks() == pytest.approx([0.2, 1.2])
    plt.close(fig)


def _drawn(fig):
    fig.canvas.draw()
    return fig


def test_label_problems_wants_a_unit_on_every_axis_with_numbers():
    import matplotlib.pyplot as plt
    from vehicle_observers.results.plotting import label_problems

    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    assert label_problems(_drawn(fig)) == ["panel 0: no x label", "panel 0: no y label"]
    ax.set_xlabel("$t$ [s]")
    ax.set_ylabel("$v_y$")
    assert label_problems(_drawn(fig)) == ["panel 0: y label '$v_y$' has no unit in brackets"]
    ax.set_ylabel("$v_y$ [m/s]")
    assert label_problems(_drawn(fig)) == []
    plt.close(fig)


def test_label_problems_accepts_shared_axes_and_word_ticks():
    import matplotlib.pyplot as plt
    from vehicle_observers.results.plotting import label_problems

    fig, (a, b) = plt.subplots(2, 1, sharex=True)
    a.plot([0, 1], [0, 1])
    b.plot([0, 1], [1, 0])
    a.set_ylabel("$r$ [rad/s]")
    b.set_ylabel("error [-]")
    b.set_xlabel("$t$ [s]")                  # the upper panel shares it
    assert label_problems(_drawn(fig)) == []
    plt.close(fig)
    fig, ax = plt.subplots()
    ax.bar(["ekf", "ukf"], [0.1, 0.2])
    ax.set_ylabel("RMSE [m/s]")               # estimator names need no unit
    assert label_problems(_drawn(fig)) == []
    plt.close(fig)


def test_label_problems_accepts_a_zoom_panel_beside_its_labelled_panel_only():
    import matplotlib.pyplot as plt
    from vehicle_observers.results.plotting import label_problems

    fig, (a, b) = plt.subplots(1, 2)
    for ax in (a, b):
        ax.plot([0, 1], [0, 1])
        ax.set_xlabel("$t$ [s]")
    b.set_ylabel("$v_y$ [m/s]")               # the label on the right panel does not cover the left
    assert label_problems(_drawn(fig)) == ["panel 0: no y label"]
    a.set_ylabel("$v_y$ [m/s]")
    b.set_ylabel("")
    assert label_problems(_drawn(fig)) == []
    plt.close(fig)
    fig, a = plt.subplots()
    im = a.imshow([[0, 1], [1, 0]])
    a.set_xlabel("error [%]")
    a.set_ylabel("speed [m/s]")
    cb = fig.colorbar(im, ax=a)                # a colour bar needs its own label
    assert label_problems(_drawn(fig)) == ["panel 1: no y label"]
    cb.set_label("enclosure [-]")
    assert label_problems(_drawn(fig)) == []
    plt.close(fig)
