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
