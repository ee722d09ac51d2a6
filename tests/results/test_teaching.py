"""The exercise checker and the animation helper of :mod:`vehicle_observers.results.teaching`."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from vehicle_observers.results import teaching as T  # noqa: E402


@pytest.mark.parametrize("answer", [..., None, (1.0, ...), lambda: None])
def test_an_empty_stub_is_not_attempted(answer):
    assert T.check("t.1", answer, 1.0, hint="h", show=False).status == T.EMPTY
    assert T.RESULTS["t.1"] == T.EMPTY


def test_a_function_that_raises_not_implemented_is_not_attempted():
    def stub():
        raise NotImplementedError

    assert T.check("t.2", stub, 1.0, hint="h", show=False).status == T.EMPTY


@pytest.mark.parametrize("answer,want,ok", [
    (1.0005, 1.0, True), (1.01, 1.0, False), ([1.0, 2.0], np.array([1.0, 2.0]), True),
    ([1.0, 2.0], np.array([1.0, 2.0, 3.0]), False), (True, True, True), (1.0, True, True), (0.0, True, False),
    ({"a": 1.0, "b": [2.0]}, {"a": 1.0, "b": [2.0]}, True), ({"a": 1.0}, {"a": 1.0, "b": 2}, False),
    (np.nan, 1.0, False), ("observable", "observable", True), ("no", "observable", False)])
def test_answers_are_compared_by_value(answer, want, ok):
    out = T.check("t.3", answer, want, hint="think", show=False)
    assert out.ok is ok
    assert (out.status == T.CORRECT) is ok
    if not ok:
        assert out.status == T.WRONG and "Hint: think" in out.message


def test_an_exception_in_the_students_code_is_a_wrong_answer_with_its_message():
    out = T.check("t.4", lambda: 1 / 0, 1.0, hint="h", show=False)
    assert out.status == T.WRONG and "ZeroDivisionError" in out.message


def test_the_html_line_carries_the_status():
    out = T.check("t.5", 2.0, 1.0, hint="h", show=False)
    assert f'data-status="{T.WRONG}"' in out._repr_html_()


def test_animation_is_a_self_contained_html_player():
    fig, ax = plt.subplots(figsize=(2, 1.5))
    (line,) = ax.plot([], [])
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)

    def update(i):
        line.set_data(np.linspace(0, 1, i + 2), np.linspace(0, 1, i + 2))

    page = T.animation(fig, update, frames=3).data
    assert "<script" in page and page.count("data:image/png;base64") == 3
    assert "http://" not in page and "https://" not in page
    with pytest.raises(ValueError, match="frames"):
        T.animation(plt.figure(), update, frames=1)


def test_frame_indices_cover_the_run():
    idx = T.frame_indices(101, 5)
    assert idx[0] == 1 and idx[-1] == 101 and np.all(np.diff(idx) > 0)


@pytest.mark.parametrize("answer, want, kw, says, never", [
    (1e-3, 0.0, dict(atol=1e-6, unit="m/s"), "should be zero (within 1e-06 m/s), yours is off by 0.001 m/s",
     "relative"),                                          # a zero target: absolute error
    (4, 3, {}, "too high", "relative"),                     # a rank: no "off by 0.33"
    (2.5, 3, {}, "expected a whole number, got 2.5", "relative"),
    ([1.0, 2.5, 3.0], [1.0, 2.0, 3.0], dict(unit="rad/s"), "entry 1: too high by 0.5 rad/s (25% of",
     "entries"),                                           # names the wrong entry, in its unit
    ({"L1": 1.0, "L2": -2.0}, {"L1": 1.0, "L2": 2.0}, {}, "['L2'] too low by 4 (200% of", "['L1']"),
    (False, True, {}, "your answer False is not right", "expected True"),
])
def test_feedback_diagnoses_without_giving_the_answer_away(answer, want, kw, says, never):
    """Catches meaningless feedback ("off by 9.1e+298 (relative)" for a zero target, "off by 0.5"
    for a rank) and feedback that names the expected value or no wrong output."""
    out = T.check("t.9", answer, want, hint="h", show=False, **kw)
    assert out.status == T.WRONG
    assert says in out.message, out.message
    assert never not in out.message.split("Hint")[0]


def test_staged_hints_come_one_per_wrong_attempt_then_stay_on_the_last():
    """Catches a staged hint list shown all at once (the last hint is often the solution)."""
    T.ATTEMPTS.pop("t.10", None)
    hints = ["which states does C measure?", "the (2,1) entry cannot change", "L has no effect there"]
    seen = [T.check("t.10", 1.0, 2.0, hint=hints, show=False).message.split("Hint: ")[1]
            for _ in range(4)]
    assert seen == hints + hints[-1:]


def test_a_live_figure_carries_its_initial_state_as_an_image_for_the_exported_page(tmp_path):
    """Catches a live figure that renders nothing in the offline HTML (no widget manager there):
    the output must hold a PNG of the initial state, which the export keeps in place of the widget."""
    import matplotlib.pyplot as plt
    import nbformat
    from IPython.core.interactiveshell import InteractiveShell
    from IPython.utils.capture import capture_output
    from nbformat.v4 import new_code_cell, new_notebook, new_output
    from vehicle_observers.results import html

    def draw(gain):
        fig, ax = plt.subplots()
        ax.plot([0, 1], [0, gain])
        return fig

    InteractiveShell.instance()   # display() publishes only through a shell
    with capture_output(display=True) as cap:
        T.live_figure(draw, gain=T.slider(1.0, 0.0, 2.0, 0.1, "gain"))
    bundles = [o.data for o in cap.outputs if html.WIDGET_VIEW in o.data]
    assert len(bundles) == 1 and "image/png" in bundles[0]
    nb = new_notebook(cells=[new_code_cell("live", outputs=[
        new_output("display_data", data={k: v for k, v in bundles[0].items()
                                         if k in (html.WIDGET_VIEW, "image/png", "text/plain")})])])
    path = tmp_path / "live.ipynb"
    nbformat.write(nb, str(path))
    page = html.write_html([path], tmp_path / "html")[0].read_text()
    assert page.count('src="data:image/png;base64,') == 1
