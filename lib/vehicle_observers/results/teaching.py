"""Teaching helpers of the notebooks: exercise checkers, live figures, animations.

Exercises
---------
Every exercise of a notebook is three cells, right after the section it practises:

1. a markdown cell starting ``**Exercise N.**`` (the task, with the paper's equation numbers);
2. a code cell tagged ``exercise``: a stub the student fills (``...  # your code here``) ending
   with a :func:`check` call;
3. a code cell tagged ``solution`` with its source hidden in JupyterLab (cell metadata
   ``jupyter.source_hidden``): a worked solution ending with the same :func:`check` call.

:func:`check` compares an answer with the expected one (computed independently in the
notebook, e.g. from the library or a closed form) and shows one line: ``correct``, ``not yet``
(with a hint) or ``not attempted`` (the stub's ``...``). It never raises, so Run All goes
through a notebook whose stubs are still empty; the tests assert that every stub cell says
``not attempted`` and every solution cell ``correct`` (:data:`RESULTS` keeps the outcomes).

Live figures and animations
---------------------------
:func:`live_figure` wraps a drawing function in ipywidgets sliders (``continuous_update=False``)
and redraws the figure on every move; it is live in quick mode too (short horizons are the
caller's business). :func:`animation` turns a matplotlib figure and an update function into an
HTML5/JavaScript player (``FuncAnimation.to_jshtml``) that plays in JupyterLab and in the
exported HTML, without a kernel.
"""

from __future__ import annotations

import html
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

#: marks of the three outcomes (the tests look for these words in the output)
CORRECT, WRONG, EMPTY = "correct", "not yet", "not attempted"

#: ``{exercise key: outcome}`` of the :func:`check` calls of this kernel (last call wins)
RESULTS: dict[str, str] = {}


@dataclass(frozen=True)
class Outcome:
    """What :func:`check` found: ``key``, ``status`` (:data:`CORRECT`, :data:`WRONG`,
    :data:`EMPTY`) and the message shown."""

    key: str
    status: str
    message: str

    @property
    def ok(self) -> bool:
        return self.status == CORRECT

    def _repr_html_(self) -> str:
        colour = {CORRECT: "#1a7f37", WRONG: "#b35900", EMPTY: "#57606a"}[self.status]
        mark = {CORRECT: "&#10004;", WRONG: "&#10008;", EMPTY: "&#9675;"}[self.status]
        return (f'<div class="vo-check" data-status="{self.status}" style="color:{colour}">'
                f"{mark} <b>Exercise {html.escape(self.key)}</b>: {html.escape(self.message)}</div>")

    def __repr__(self) -> str:
        return f"Exercise {self.key}: {self.message}"


def _is_empty(answer) -> bool:
    return answer is None or answer is Ellipsis or (
        isinstance(answer, (tuple, list)) and any(a is None or a is Ellipsis for a in answer))


def _is_count(want) -> bool:
    """An integer target (a rank, a count, an index): Python or numpy integers, not floats."""
    if isinstance(want, (bool, np.bool_)):
        return False
    if isinstance(want, (int, np.integer)):
        return True
    a = np.asarray(want)
    return a.dtype.kind in "iu"


def _compare(got, want, rtol: float, atol: float, unit: str = "") -> tuple[bool, str]:
    """``(correct, diagnosis)``. The diagnosis says what is wrong without giving the expected
    value away: which key or entries, by how much in the answer's own unit (absolute where the
    expected value is zero, relative elsewhere), too high or too low for a whole number, and
    what was expected of a boolean or a text."""
    u = f" {unit}" if unit else ""
    if isinstance(want, (bool, np.bool_)):
        if isinstance(got, (int, float, np.integer, np.floating)) and got in (0, 1):
            got = bool(got)   # 1 / 0 for True / False
        if not isinstance(got, (bool, np.bool_)):
            return False, f"expected True or False, got {type(got).__name__} {got!r:.40}"
        return bool(got) == bool(want), f"your answer {bool(got)} is not right"
    if isinstance(want, str) or want is None:
        return got == want, f"your answer {got!r:.40} is not the expected {type(want).__name__}"
    if isinstance(want, dict):
        if not isinstance(got, dict) or set(got) != set(want):
            keys = sorted(map(str, want))
            return False, f"expected a dict with keys {keys}"
        bad = []
        for k in want:
            ok, why = _compare(got[k], want[k], rtol, atol, unit)
            if not ok:
                bad.append(f"[{k!r}] {why}")
        return (not bad), "; ".join(bad[:3]) + (f" (and {len(bad) - 3} more keys)" if len(bad) > 3 else "")
    try:
        g = np.asarray(got, dtype=float)
        w = np.asarray(want, dtype=float)
    except (TypeError, ValueError):
        return False, f"expected a number or an array like {np.shape(want)}, got {type(got).__name__}"
    if g.shape != w.shape:
        return False, f"expected shape {w.shape}, got {g.shape}"
    if not np.all(np.isfinite(g)):
        return False, "the answer has NaN or infinite entries"
    close = np.isclose(g, w, rtol=rtol, atol=atol)
    if bool(np.all(close)):
        return True, ""
    wrong = np.argwhere(~close)
    where = ("" if w.ndim == 0 else
             f"entr{'y' if len(wrong) == 1 else 'ies'} "
             + ", ".join(str(tuple(int(i) for i in ix)) if w.ndim > 1 else str(int(ix[0]))
                         for ix in wrong[:4]) + (" ..." if len(wrong) > 4 else "") + ": ")
    if _is_count(want):
        gw = g[~close]
        if not np.all(gw == np.round(gw)):
            return False, f"{where}expected a whole number, got {gw.ravel()[0]:g}"
        direction = "too high" if np.all(gw > w[~close]) else "too low" if np.all(gw < w[~close]) else "off"
        return False, f"{where}{direction}"
    d = np.abs(g - w)[~close]
    ww = np.abs(w)[~close]
    if np.any(ww == 0):   # a zero target: only an absolute error means something
        return False, (f"{where}should be zero (within {max(atol, 0.0):g}{u}), yours is off by "
                       f"{d.max():.3g}{u}")
    rel = float(np.max(d / ww))
    sign = "too high" if np.all((g - w)[~close] > 0) else "too low" if np.all((g - w)[~close] < 0) else "off"
    return False, f"{where}{sign} by {d.max():.3g}{u} ({rel:.0%} of the expected size)"


#: ``{exercise key: wrong attempts so far}`` (staged hints, :func:`check`)
ATTEMPTS: dict[str, int] = {}


def check(key: str, answer, expected, *, hint, rtol: float = 1e-3, atol: float = 0.0,
          unit: str = "", show: bool = True) -> Outcome | None:
    """Grade exercise ``key`` (e.g. ``"03.2"``): ``answer`` against ``expected``.

    ``answer`` may be a value, an array, a dict of them, or a callable taking no argument (called
    here, so an exception in the student's code becomes a ``not yet`` line with its message).
    ``...``/``None`` (also inside a tuple) means the stub is still empty. Numbers are compared with
    ``numpy.isclose(rtol, atol)``; bools and strings exactly. A wrong answer gets a diagnosis
    that gives nothing away (:func:`_compare`: which key or entries are wrong, too high or too
    low, by how much in ``unit``) and a hint: ``hint`` is one sentence or a list of staged hints,
    the next one shown at each wrong attempt. Displays one line and returns ``None`` in a
    notebook (``show=True``), else the :class:`Outcome`; the outcome is also kept in
    :data:`RESULTS`."""
    hints = [hint] if isinstance(hint, str) else list(hint)
    if callable(answer):
        try:
            answer = answer()
        except NotImplementedError:
            answer = None
        except Exception as exc:  # the student's code: report it, never stop Run All
            out = Outcome(key, WRONG, f"your code raised {type(exc).__name__}: {exc}. "
                                      f"Hint: {_next_hint(key, hints)}")
            return _finish(out, show)
    if _is_empty(answer):
        out = Outcome(key, EMPTY, "fill in the cell above (replace ...), then run it again")
    else:
        ok, why = _compare(answer, expected, rtol, atol, unit)
        out = (Outcome(key, CORRECT, "correct") if ok
               else Outcome(key, WRONG, f"{why}. Hint: {_next_hint(key, hints)}"))
    return _finish(out, show)


def _next_hint(key: str, hints: list[str]) -> str:
    n = ATTEMPTS.get(key, 0)
    ATTEMPTS[key] = n + 1
    return hints[min(n, len(hints) - 1)] if hints else "read the section above again"


def _finish(out: Outcome, show: bool):
    RESULTS[out.key] = out.status
    if not show:
        return out
    try:
        from IPython.display import display
    except ImportError:  # pragma: no cover - IPython comes with the notebooks
        print(repr(out))
        return None
    display(out)
    return None


# ----------------------------------------------------------------------- live figures --------

def slider(value: float, lo: float, hi: float, step: float, description: str, integer: bool = False):
    """An ipywidgets slider that updates on release (``continuous_update=False``)."""
    import ipywidgets as w

    cls = w.IntSlider if integer else w.FloatSlider
    return cls(value=value, min=lo, max=hi, step=step, description=description,
               continuous_update=False, style={"description_width": "initial"},
               layout=w.Layout(width="420px"))


def live_figure(draw: Callable, **sliders):
    """Show ``draw(**values)`` (a function that builds and returns a matplotlib figure) under
    the given ipywidgets ``sliders`` (name -> widget, e.g. from :func:`slider`), redrawn on every
    move. Shown at once (also under papermill, with the initial values); returns ``None``.
    The output also carries the initial figure as a PNG, which a page without a widget
    manager (the exported HTML) shows instead of nothing.

    The figure is shown as a PNG inside an ``Output`` widget, so the image changes in the page
    when a slider moves (what the browser test checks)."""
    import ipywidgets as w
    import matplotlib.pyplot as plt
    from IPython.display import display

    out = w.Output()
    first: dict[str, str] = {}

    def redraw(**values):
        with out:
            out.clear_output(wait=True)
            fig = draw(**values)
            if fig is not None:
                if not first:   # the initial state, also as a static image (see below)
                    first["png"] = _png_base64(fig)
                display(fig)
                plt.close(fig)

    redraw(**{k: s.value for k, s in sliders.items()})
    controls = w.interactive(redraw, **sliders)
    controls.children[-1].layout.display = "none"  # interactive's own (empty) output area
    box = w.VBox([w.HBox(list(controls.children[:-1])), out],
                 layout=w.Layout(border="1px solid #d0d7de", padding="4px"))
    bundle = box._repr_mimebundle_()
    # where no widget manager runs (exported HTML, a terminal) the text says what is missing,
    # instead of the widget's repr
    bundle["text/plain"] = (f"[live figure with sliders {', '.join(sliders)}: open the notebook "
                            "in JupyterLab with a running kernel to use it]")
    # the initial state as a PNG in the same output: JupyterLab shows the live widget, a page
    # without a widget manager (the exported HTML, :func:`vehicle_observers.results.html.static_widgets`)
    # shows this image
    if first:
        bundle["image/png"] = first["png"]
    display(bundle, raw=True)
    return None


def _png_base64(fig) -> str:
    import base64
    import io

    buf = io.BytesIO()
    fig.savefig(buf, format="png", metadata={"Software": None})
    return base64.b64encode(buf.getvalue()).decode("ascii")


# ----------------------------------------------------------------------- animations ----------

def animation(fig, update: Callable[[int], object], frames: int, interval_ms: int = 80,
              dpi: int = 60):
    """An HTML5/JavaScript player of ``frames`` frames of ``fig`` (``update(i)`` redraws frame
    ``i``), as an ``IPython.display.HTML`` object: it plays in JupyterLab and in the exported
    HTML without a kernel. ``fig`` is closed (so it is not shown a second time). Keep ``frames``
    x figure size small: every frame is an embedded PNG (``dpi``)."""
    import matplotlib.pyplot as plt
    from IPython.display import HTML
    from matplotlib import animation as anim

    if frames < 2:
        raise ValueError(f"animation: frames must be >= 2, got {frames}")
    fig.set_dpi(dpi)
    a = anim.FuncAnimation(fig, update, frames=frames, interval=interval_ms, blit=False)
    page = a.to_jshtml(fps=max(1, round(1000 / interval_ms)), default_mode="once")
    plt.close(fig)
    return HTML(_offline_player(page))


#: the player's button icons as plain ASCII text: matplotlib's page loads Font Awesome from a
#: CDN, which an offline page or a blocked network leaves as blank buttons, and the Unicode
#: media symbols (U+23EE...) are missing from the fonts of a plain Chromium (blank boxes)
_ICONS = {"fa-play": ">", "fa-pause": "||", "fa-fast-backward": "|<<",
          "fa-fast-forward": ">>|", "fa-step-backward": "|<",
          "fa-step-forward": ">|", "fa-minus": "-", "fa-plus": "+"}


def _offline_player(page: str) -> str:
    """``page`` without its external stylesheet link, the icons drawn as text."""
    import re

    page = re.sub(r"<link[^>]*font-awesome[^>]*>", "", page)
    css = "".join(f'.anim-buttons .{k}:before{{content:"{v}";font-style:normal;'
                  f'font-family:monospace;font-weight:bold}}' for k, v in _ICONS.items())
    return f"<style>{css}</style>\n{page}"


def frame_indices(n_samples: int, frames: int) -> np.ndarray:
    """``frames`` sample indices spread over ``n_samples`` (first and last included), for
    animations that reveal a trajectory progressively."""
    if n_samples < 1 or frames < 2:
        raise ValueError(f"frame_indices: need n_samples >= 1 and frames >= 2, got "
                         f"{n_samples}, {frames}")
    return np.unique(np.round(np.linspace(1, n_samples, frames)).astype(int))


def reading_time(words: int, code_cells: int) -> int:
    """Reading time [min] of a notebook: 200 words a minute plus one minute per code cell."""
    return math.ceil(words / 200 + code_cells)


# ----------------------------------------------------------------------- lessons -------------

class Lesson:
    """The figure helper of a lesson notebook (``notebooks/NN_name.ipynb``).

    A lesson teaches; it records no metric, claim or verdict (those live in the section's
    reproduction report, ``notebooks/reports/NN_name_report.ipynb``, through
    :class:`~vehicle_observers.results.reporting.Report`). ``Lesson`` only shows a figure
    inline and saves it as ``<figures_dir>/<notebook>/lesson/<name>.png`` (``figures_dir=None``,
    the default of every ``parameters`` cell: ``build/interactive/``, ignored by git), with the
    same axis-label checks as the report's figures.

    Usage::

        lesson = Lesson("03_interval_observer", figures_dir, quick=quick, seed=seed)
        lesson.savefig(fig, "band_vs_truth")
    """

    def __init__(self, notebook: str, figures_dir=None, quick: bool = False, seed: int = 0,
                 show: bool | None = None):
        from pathlib import Path

        from vehicle_observers.results.reporting import _in_kernel, interactive_dir, validate_parameters

        self.notebook = notebook
        self.quick, self.seed = validate_parameters(quick, seed)
        base = interactive_dir() if figures_dir is None else Path(figures_dir)
        self.dir = base / notebook / "lesson"
        self.dir.mkdir(parents=True, exist_ok=True)
        self.show = _in_kernel() if show is None else bool(show)
        #: ``{figure: axis-label problems}`` of the figures saved so far
        self.figure_problems: dict[str, list[str]] = {}
        #: ``{figure: what it shows}``, written to ``figure_data.json`` beside the figures and
        #: compared by the regeneration check (:mod:`vehicle_observers.results.check`)
        self.figure_data: dict[str, dict] = {}

    def savefig(self, fig, name: str, close: bool = True):
        """Save ``fig`` as ``<name>.png`` in the lesson's folder and show it inline. Returns
        ``None`` so that a cell ending with it prints nothing."""
        import json

        import matplotlib.pyplot as plt

        from vehicle_observers.results.plotting import figure_data, label_problems
        from vehicle_observers.results.reporting import figure_checks_path, jsonable, write_figure_data

        if "/" in name or "." in name:
            raise ValueError(f"figure name {name!r}: no extension or folder, e.g. 'band_vs_truth'")
        fig.tight_layout()
        png = self.dir / f"{name}.png"
        fig.savefig(png, metadata={"Software": None})
        self.figure_problems[name] = label_problems(fig)
        self.figure_data[name] = jsonable(figure_data(fig))
        write_figure_data(self.dir, self.figure_data)
        path = figure_checks_path(self.dir)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps({"notebook": self.notebook, "quick": self.quick,
                                    "figures_dir": str(self.dir.resolve()),
                                    "problems": self.figure_problems}, indent=1) + "\n")
        if self.show:
            from IPython.display import Image, display

            display(Image(filename=str(png)))
        if close:
            plt.close(fig)
        return None
