"""One helper for every notebook: figures into ``figures/<notebook>/``, metrics and claims.

Usage in a notebook::

    rep = Report("01_ts_exactness", figures_dir, quick=quick, seed=seed)
    rep.savefig(fig, "fig1_real_log")                 # shown inline, saved as PNG (+ PDF)
    rep.metric("rmse_vy_ts", 0.28, "m/s")             # stored at 4 significant digits
    rep.claim("Yacine 2015", "Fig. 1", "fig1_real_log", "yaw-rate fit",
              Rule("fit_r", reproduced="value >= 0.95", paper="model fits the measurements",
                   source="chosen here: the paper prints no number"))      # kind="paper"
    rep.timing("observer_us_per_step", 0.8, "us")     # wall clock: build/timings/, never committed
    rep.record(metrics={"rmse_r": (0.01, "rad/s", "note")},    # many at once, in order
               claims=[dict(paper=..., item=..., figure=..., metric=..., rule=Rule(...))],
               timings={"solve_s": (1.2, "s")})
    rep.write()                                       # metrics.json

The verdict of a claim is computed by its :class:`~vehicle_observers.results.rules.Rule` from
the metrics recorded before it, never written by hand. Its ``kind`` (``rules.KINDS``) says
whether it is a claim printed in a paper (``"paper"``, the default) or a check made beside the
papers (``"target"``, ``"diagnostic"``, ``"baseline"``, ``"data"``); REPRODUCTION.md counts
the kinds apart. ``metrics.json`` holds the metrics (with
their precision and, where a value depends on the solver or the platform beyond that precision,
its tolerance and the reason), the claims with their rules and verdicts (read by the pipeline
to build REPRODUCTION.md) and the list of files written. Files are written deterministically
(no timestamps, fixed hash salt). Wall-clock measurements go to ``build/timings/<notebook>.json``
(ignored by git): they differ on every run and are reported by ``make bench``.

``figures_dir=None`` (the default of every notebook's ``parameters`` cell) writes to
``build/interactive/`` (ignored by git): only the pipeline writes the committed ``figures/``.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.data.logs import repo_root
from vehicle_observers.results import plotting  # noqa: F401  (applies the one figure style)
from vehicle_observers.results.plotting import figure_data, label_problems
from vehicle_observers.results.rules import (
    KINDS,
    VERDICTS,
    Rule,
    RuleError,
    distinguishing_digits,
    fmt,
    round_sig,
)

__all__ = ["Report", "Rule", "VERDICTS", "KINDS", "load_metrics", "interactive_dir", "jsonable"]


def interactive_dir() -> Path:
    """Where interactive runs write (``build/interactive``, ignored by git)."""
    return repo_root() / "build" / "interactive"


def jsonable(v):
    """``v`` as JSON: numpy scalars and arrays as numbers and lists, non-finite floats as
    strings (``"nan"``, ``"inf"``), dict keys as strings."""
    if isinstance(v, (np.floating, float)):
        v = float(v)
        return v if math.isfinite(v) else str(v)
    if isinstance(v, (np.integer,)):
        return int(v)
    if isinstance(v, (np.bool_,)):
        return bool(v)
    if isinstance(v, np.ndarray):
        return [jsonable(x) for x in v.tolist()]
    if isinstance(v, (list, tuple)):
        return [jsonable(x) for x in v]
    if isinstance(v, dict):
        return {str(k): jsonable(x) for k, x in v.items()}
    return v


@dataclass
class Claim:
    paper: str
    item: str
    figure: str
    metric: str
    value: object
    target: str
    verdict: str
    note: str = ""
    rule: str = ""
    proves_little: bool = False
    rule_def: dict = field(default_factory=dict)
    kind: str = "paper"
    duplicate_of: str = ""


def validate_parameters(quick, seed) -> tuple[bool, int]:
    """The papermill parameters ``quick`` and ``seed`` of a notebook, checked: ``quick`` a
    real boolean (or ``0``/``1``), ``seed`` a whole number; anything else raises
    :class:`~vehicle_observers.core.errors.ObserverArgumentError` naming the parameter, so a
    misread ``-r quick no`` or ``-p seed 1.5`` never runs with another value."""
    if isinstance(quick, (bool, np.bool_)) or (isinstance(quick, (int, np.integer)) and quick in (0, 1)):
        q = bool(quick)
    else:
        raise ObserverArgumentError(f"parameter quick must be True or False, got {quick!r} "
                                    f"({type(quick).__name__}); with papermill use -p quick True")
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        raise ObserverArgumentError(f"parameter seed must be a whole number, got {seed!r} "
                                    f"({type(seed).__name__})")
    return q, int(seed)


def _in_kernel() -> bool:
    try:
        from IPython import get_ipython
    except ImportError:  # pragma: no cover - IPython is a dependency of the notebooks
        return False
    ip = get_ipython()
    return ip is not None and hasattr(ip, "kernel")


class Report:
    """Collects figures, metrics and paper claims of one notebook."""

    def __init__(self, notebook: str, figures_dir=None, quick: bool = False,
                 seed: int = 0, formats=("png", "pdf"), show: bool | None = None):
        from vehicle_observers.results.parameters import validate_parameters

        quick, seed = validate_parameters(quick=quick, seed=seed)   # before any folder
        self.notebook = notebook
        base = interactive_dir() if figures_dir is None else Path(figures_dir)
        self.dir = base / notebook
        self.dir.mkdir(parents=True, exist_ok=True)
        self.quick, self.seed = validate_parameters(quick, seed)
        self.formats = tuple(formats)
        self.show = _in_kernel() if show is None else bool(show)
        self.metrics: dict[str, dict] = {}
        self.claims: list[Claim] = []
        self.files: list[str] = []
        self.timings: dict[str, dict] = {}
        #: ``{figure: axis-label problems}`` (:func:`~vehicle_observers.results.plotting.label_problems`),
        #: written beside the timings, never into metrics.json
        self.figure_problems: dict[str, list[str]] = {}
        #: ``{figure: what it shows}`` (:func:`~vehicle_observers.results.plotting.figure_data`),
        #: written to ``figure_data.json`` and compared by the regeneration check
        self.figure_data: dict[str, dict] = {}

    # ------------------------------------------------------------------ figures ----------
    def savefig(self, fig, name: str, close: bool = True):
        """Save ``fig`` as ``<name>.png`` (and the other formats) in the notebook's folder and,
        in a notebook, show it inline (as the saved PNG, whatever the matplotlib backend).
        Returns ``None`` so that a cell ending with it prints nothing."""
        if "/" in name or "." in name:
            raise ValueError(f"figure name {name!r}: no extension or folder, e.g. 'fig2_vy'")
        fig.tight_layout()
        for ext in self.formats:
            fn = f"{name}.{ext}"
            meta = {"Software": None} if ext == "png" else {"CreationDate": None, "Creator": None,
                                                              "Producer": None}
            fig.savefig(self.dir / fn, metadata=meta)
            if fn not in self.files:
                self.files.append(fn)
        self.figure_problems[name] = label_problems(fig)   # tick labels exist once drawn
        self.figure_data[name] = jsonable(figure_data(fig))
        png = self.dir / f"{name}.png"
        if self.show:
            from IPython.display import Image, display

            display(Image(filename=str(png)))
        if close:
            plt.close(fig)
        return None

    def path(self, name: str) -> Path:
        """Path of a saved figure (``<name>.png``)."""
        return self.dir / f"{name}.png"

    # ------------------------------------------------------------------ metrics ----------
    def metric(self, name: str, value, unit: str = "", note: str = "", digits: int = 4,
               rtol: float | None = None, atol: float | None = None, why: str = ""):
        """Record a metric, stored at ``digits`` significant digits. ``rtol``/``atol``: the
        tolerance ``make check`` allows between two regenerations when the value depends on
        the solver or the platform beyond that precision (give the reason in ``why``).
        Returns the stored (rounded) value."""
        if (rtol is not None or atol is not None) and not why:
            raise ValueError(f"metric {name!r}: say why the tolerance is needed (why=...)")
        stored = round_sig(jsonable(value), digits)
        entry = {"value": stored, "unit": unit, "note": note, "digits": digits}
        if rtol is not None:
            entry["rtol"] = float(rtol)
        if atol is not None:
            entry["atol"] = float(atol)
        if why:
            entry["why"] = why
        self.metrics[name] = entry
        return stored

    def values(self) -> dict:
        """``{metric name: stored value}``."""
        return {k: v["value"] for k, v in self.metrics.items()}

    def timing(self, name: str, value, unit: str = "s", note: str = ""):
        """A wall-clock measurement: written to ``build/timings/<notebook>.json`` (ignored by
        git), never to metrics.json, so regeneration leaves the committed files unchanged."""
        self.timings[name] = {"value": jsonable(value), "unit": unit, "note": note}
        return value

    # ------------------------------------------------------------------ claims -----------
    def claim(self, paper: str, item: str, figure: str, metric: str, rule: Rule,
              note: str = "", kind: str = "paper", duplicate_of: str = ""):
        """Record one claim; its verdict is computed by ``rule`` (a
        :class:`~vehicle_observers.results.rules.Rule`) from the metrics recorded so far. There
        is no way to pass a verdict: it is never written by hand. ``kind``: ``"paper"`` (a
        claim printed in a paper), ``"target"``, ``"diagnostic"``, ``"baseline"`` or ``"data"``
        (checks made beside the papers; see ``rules.KINDS``). ``duplicate_of``
        (``"<notebook>: <item>"``): the same claim of the same paper is graded elsewhere; the
        row is listed with a reference to it and not counted again in the tallies. The value is stored at 4
        significant digits, more when needed to tell it from a threshold of the rule."""
        if not isinstance(rule, Rule):
            raise TypeError(f"claim {paper} {item}: rule must be a Rule (the verdict is computed "
                            f"from it), got {type(rule).__name__}")
        if kind not in KINDS:
            raise ObserverArgumentError(f"claim {paper} {item}: kind must be one of "
                                        f"{', '.join(KINDS)}, got {kind!r}")
        values = self.values()
        j = rule.judge(values)
        value = jsonable(j.value)
        try:
            digits = distinguishing_digits(value, rule.thresholds(values), 4)
        except RuleError:  # pragma: no cover - judge() evaluated the same expressions
            digits = 4
        self.claims.append(Claim(paper, item, figure, metric, round_sig(value, digits),
                                 rule.paper, j.verdict, note, rule.text(), j.proves_little,
                                 {k: v for k, v in asdict(rule).items() if v is not None},
                                 kind, duplicate_of))
        return j

    def record(self, *, metrics: dict | None = None, claims=(), timings: dict | None = None):
        """Record many entries at once, in order: ``metrics`` ``{name: (value, unit, note)}``
        (unit and note optional) with :meth:`metric`, then ``timings`` (same form, wall
        clock) with :meth:`timing`, then ``claims``, keyword dicts of :meth:`claim` (each
        verdict computed from the metrics recorded so far, these included). The experiment
        functions of the reproductions return their metrics and claims in these forms.
        Returns ``None``, so that a notebook cell ending with it shows nothing."""
        for kind, entries, add in (("metrics", metrics, self.metric),
                                   ("timings", timings, self.timing)):
            for name, v in (entries or {}).items():
                if not isinstance(v, tuple) or not 1 <= len(v) <= 3:
                    raise ObserverArgumentError(
                        f"Report.record: {kind}[{name!r}] must be a tuple (value, unit, note) "
                        f"with unit and note optional, got {type(v).__name__} {v!r:.60}")
                add(name, *v)
        for c in claims:
            if not isinstance(c, dict):
                raise ObserverArgumentError(f"Report.record: each claim is a dict of "
                                            f"Report.claim's arguments, got {type(c).__name__}")
            self.claim(**c)
        return None

    # ------------------------------------------------------------------ output -----------
    def write(self) -> None:
        """Write ``metrics.json`` (its path: :attr:`metrics_path`) and the timings. Returns
        ``None``, so that a notebook cell ending with it shows nothing."""
        path = self.metrics_path
        doc = {"notebook": self.notebook, "quick": self.quick, "seed": self.seed,
               "metrics": self.metrics, "claims": [{k: v for k, v in c.__dict__.items()
                           if k != "duplicate_of" or v} for c in self.claims],
               "files": sorted(self.files + ["metrics.json"]
                               + (["figure_data.json"] if self.figure_data else []))}
        path.write_text(json.dumps(jsonable(doc), indent=1, sort_keys=False) + "\n")
        if self.figure_data:
            write_figure_data(self.dir, self.figure_data)
        if self.figure_problems:
            path = figure_checks_path(self.dir)
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(json.dumps({"notebook": self.notebook, "quick": self.quick,
                                        "figures_dir": str(self.dir.resolve()),
                                        "problems": self.figure_problems}, indent=1) + "\n")
        if self.timings:
            tdir = repo_root() / "build" / "timings"
            tdir.mkdir(parents=True, exist_ok=True)
            (tdir / f"{self.notebook}.json").write_text(
                json.dumps({"notebook": self.notebook, "quick": self.quick,
                            "timings": jsonable(self.timings)}, indent=1) + "\n")
        return None

    @property
    def metrics_path(self) -> Path:
        """Where :meth:`write` writes ``metrics.json``."""
        return self.dir / "metrics.json"

    def metric_table(self, names, digits: int = 3, title: str = ""):
        """Table of recorded metrics for a reader: one row per name with its description (the
        metric's note, else its name), value and unit, so no internal key name is shown alone."""
        from vehicle_observers.results.tables import show_table

        rows = []
        for n in names:
            if n not in self.metrics:
                raise KeyError(f"metric_table: no metric {n!r} recorded yet")
            m = self.metrics[n]
            rows.append({"quantity": m["note"] or n, "value": m["value"], "unit": m["unit"] or "-"})
        return show_table(rows, ["quantity", "value", "unit"], digits, title)

    def table(self, rows, columns=None, digits: int = 3):
        """Show rows (list of dicts) as a rounded HTML table in a notebook (text elsewhere)."""
        from vehicle_observers.results.tables import show_table

        return show_table(rows, columns, digits)


def figure_checks_path(figures_dir) -> Path:
    """Where :meth:`Report.write` puts the axis-label problems of the figures saved in
    ``figures_dir`` (a notebook's own folder): ``build/figure_checks/<notebook>-<hash>.json``,
    one file per figures folder, so runs of the same notebook into other folders (the tests,
    the browser test, the pipeline) never overwrite each other's."""
    d = Path(figures_dir).resolve()
    h = hashlib.sha1(str(d).encode()).hexdigest()[:12]
    return repo_root() / "build" / "figure_checks" / f"{d.name}-{h}.json"


def write_figure_data(folder, data: dict) -> Path:
    """Write ``{figure: what it shows}`` to ``<folder>/figure_data.json`` (sorted, one
    indentation level per nesting, deterministic)."""
    path = Path(folder) / "figure_data.json"
    path.write_text(json.dumps(jsonable(data), indent=1, sort_keys=True) + "\n")
    return path


def load_metrics(path) -> dict:
    """Read a metrics.json; returns ``{name: value}`` plus the raw document as ``_doc``."""
    doc = json.loads(Path(path).read_text())
    out = {k: v["value"] for k, v in doc["metrics"].items()}
    out["_doc"] = doc
    return out


__all__ += ["fmt"]
