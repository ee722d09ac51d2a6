"""The learning path through the notebooks: order, prerequisites, objectives, reading time.

:data:`STEPS` holds one :class:`Step` per notebook (its number, title, the notebooks it builds on
and what a student can do after it). :func:`reading_times` reads every notebook file and computes
its reading time with :func:`vehicle_observers.results.teaching.reading_time` (200 words a minute
of markdown plus one minute per code cell), so the figure follows the notebooks as they change.
:func:`fig_learning_path` draws the path (arrows from a prerequisite to the notebook that needs
it).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import matplotlib.pyplot as plt
import nbformat
from vehicle_observers.data.logs import repo_root
from vehicle_observers.results import plotting
from vehicle_observers.results.teaching import reading_time


@dataclass(frozen=True)
class Step:
    """One notebook of the path: ``number`` (``"03"``), ``title``, ``needs`` (the numbers of
    the notebooks to read first), ``objectives`` (what a student can do after it)."""

    number: str
    title: str
    needs: tuple[str, ...]
    objectives: tuple[str, ...]


STEPS: tuple[Step, ...] = (
    Step("00", "Start here: path, notation, observer families", (),
         ("find the notebook that answers a question", "read every notebook in one notation",
          "run a registered estimator and score it")),
    Step("01", "Exact TS models by sector nonlinearity", ("00",),
         ("write a nonlinear model as an exact convex blend of linear models",
          "say where the exactness holds (the sector) and what it costs (2^p rules)",
          "fit the model to a real log")),
    Step("02", "Premise estimation and the TS observer (Yacine 2015)", ("01",),
         ("differentiate a noisy signal with a sliding-mode differentiator",
          "estimate an unmeasured premise from a camera", "design a TS observer by LMIs "
          "and read its error bound")),
    Step("03", "Switched TS interval observer (Ifqir 2017)", ("01",),
         ("turn a parameter box into guaranteed bounds (Metzler, positivity)",
          "write and certify the ISS LMIs of an interval observer",
          "tell a certified design from an inconclusive one")),
    Step("04", "DMVT observer and LMI pole regions (Ichalal 2011)", ("01",),
         ("handle unmeasured premises with the differential mean value theorem",
          "place observer poles in an LMI region", "compare with an EKF/UKF on the same data")),
    Step("05", "Sliding-mode observers: tyre forces, road (Rabhi 2004)", ("02",),
         ("reach a sliding surface in finite time", "recover an unknown input by the "
          "equivalent injection", "trade chattering against accuracy with a boundary layer")),
    Step("06", "Relaxed unknown-input observer (El Youssfi 2020)", ("02",),
         ("decouple an unknown input exactly (UIO structure)",
          "estimate an actuator and a sensor fault", "relax LMIs with slack variables")),
    Step("07", "One benchmark for every observer", ("02", "03"),
         ("score any registered estimator on emulated and real logs",
          "set an EKF/UKF/RTS baseline beside a paper's observer",
          "diagnose a model from the filter's innovations")),
    Step("08", "Robustness campaigns", ("03", "07"),
         ("run estimators against wrong vehicle files and noise on Dask",
          "map where an interval observer's guarantee holds",
          "read a campaign report")),
)


def step(number: str) -> Step:
    """The :class:`Step` of notebook ``number`` (``"03"``)."""
    for s in STEPS:
        if s.number == number:
            return s
    raise KeyError(f"no notebook {number!r} in the learning path")


def notebook_files(root: Path | None = None) -> dict[str, Path]:
    """``{number: path}`` of the notebooks in ``notebooks/`` (``NN_*.ipynb``)."""
    root = root or repo_root()
    return {p.name[:2]: p for p in sorted((root / "notebooks").glob("[0-9][0-9]_*.ipynb"))}


def notebook_size(path) -> tuple[int, int]:
    """``(words of markdown, code cells)`` of a notebook file."""
    nb = nbformat.read(str(path), as_version=4)
    words = sum(len(c.source.split()) for c in nb.cells if c.cell_type == "markdown")
    code = sum(c.cell_type == "code" for c in nb.cells)
    return words, code


def reading_times(root: Path | None = None) -> list[dict]:
    """One row per notebook of :data:`STEPS` present in ``notebooks/``: ``notebook``,
    ``title``, ``read first``, ``you will be able to`` (the objectives), ``words`` (markdown),
    ``code cells`` and ``reading [min]`` (:func:`~vehicle_observers.results.teaching.reading_time`)."""
    files = notebook_files(root)
    rows = []
    for s in STEPS:
        if s.number not in files:
            continue
        words, code = notebook_size(files[s.number])
        rows.append({"notebook": files[s.number].stem, "title": s.title,
                     "read first": ", ".join(s.needs) or "-",
                     "you will be able to": "; ".join(s.objectives), "words": words,
                     "code cells": code, "reading [min]": reading_time(words, code)})
    return rows


def levels() -> dict[str, int]:
    """Depth of each notebook in the path: 0 without prerequisites, else one more than its
    deepest prerequisite. Raises ValueError when a prerequisite comes later in the numbering
    (the path must be readable in the order of the numbers)."""
    depth: dict[str, int] = {}
    for s in STEPS:
        late = [n for n in s.needs if n not in depth]
        if late:
            raise ValueError(f"notebook {s.number} needs {late}, which come later in the path")
        depth[s.number] = 1 + max((depth[n] for n in s.needs), default=-1)
    return depth


#: position (column, row) of each notebook's box in :func:`fig_learning_path`, chosen so that no
#: arrow crosses a box; a notebook not listed goes to its depth's column (:func:`levels`)
LAYOUT = {"00": (0, 0.0), "01": (1, 0.0), "02": (2, 1.1), "03": (2, 0.0), "04": (2, -1.1),
          "05": (3, 1.5), "06": (3, 0.6), "07": (3, -0.6), "08": (4, -0.3)}


def fig_learning_path():
    """The path as a graph: one box per notebook (columns by depth), an arrow from the right
    edge of each prerequisite's box to the left edge of the box of the notebook that needs it."""
    depth = levels()
    fig, ax = plt.subplots(figsize=(10.0, 4.4))
    boxes = {}
    for s in STEPS:
        x, y = LAYOUT.get(s.number, (depth[s.number], -1.6))
        words = s.title.split(":")[0].split(" (")[0]
        boxes[s.number] = ax.text(x, y, f"{s.number}\n{_wrap(words, 22)}", ha="center",
                                  va="center", fontsize=7.5,
                                  bbox=dict(boxstyle="round,pad=0.4", fc=plotting.PALETTE[7],
                                            ec=plotting.PALETTE[0]))
    for s in STEPS:
        for n in s.needs:
            ax.annotate("", xy=(0.0, 0.5), xycoords=boxes[s.number], xytext=(1.0, 0.5),
                        textcoords=boxes[n],
                        arrowprops=dict(arrowstyle="-|>", color=plotting.PALETTE[3], lw=1.0,
                                        shrinkA=4, shrinkB=4))
    ax.set_xlim(-0.6, max(depth.values()) + 0.6)
    ax.set_ylim(-1.6, 1.9)
    ax.set_xticks(range(max(depth.values()) + 1))
    ax.set_xticklabels([f"step {d + 1}" for d in range(max(depth.values()) + 1)])
    ax.set_yticks([])
    ax.grid(False)
    ax.set_title("Learning path: an arrow goes from a notebook to one that builds on it")
    return fig


def _wrap(text: str, width: int) -> str:
    import textwrap

    return "\n".join(textwrap.wrap(text, width))
