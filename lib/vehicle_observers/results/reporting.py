"""One helper for every notebook: figures into ``figures/<notebook>/``, metrics and claims.

Usage in a notebook::

    rep = Report("01_ts_exactness", figures_dir, quick=quick, seed=seed)
    rep.savefig(fig, "fig1_real_log")                 # PNG (+ PDF)
    rep.metric("rmse_vy_ts", 0.28, "m/s")
    rep.claim("Yacine 2015", "Fig. 1", "fig1_real_log", "yaw-rate fit", 0.98,
              target="model fits the measurements", verdict="reproduced", note="...")
    rep.write()                                         # metrics.json

``metrics.json`` holds the metrics, the claims (read by the pipeline to build
REPRODUCTION.md) and the list of files written, so a test can check that every file in
``figures/`` comes from a notebook. Files are written deterministically (no timestamps).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt
import numpy as np

matplotlib.rcParams.update({
    "figure.dpi": 100, "savefig.dpi": 110, "figure.figsize": (9.0, 5.0), "axes.grid": True,
    "grid.alpha": 0.3, "font.size": 9, "legend.fontsize": 8, "axes.titlesize": 10,
    "lines.linewidth": 1.1, "svg.hashsalt": "vehicle-observers", "path.simplify": True,
})

VERDICTS = ("reproduced", "partly", "differs", "not comparable")


def _jsonable(v):
    if isinstance(v, (np.floating, float)):
        v = float(v)
        return v if math.isfinite(v) else str(v)
    if isinstance(v, (np.integer,)):
        return int(v)
    if isinstance(v, (np.bool_,)):
        return bool(v)
    if isinstance(v, np.ndarray):
        return [_jsonable(x) for x in v.tolist()]
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
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


class Report:
    """Collects figures, metrics and paper claims of one notebook."""

    def __init__(self, notebook: str, figures_dir="../figures", quick: bool = False,
                 seed: int = 0, formats=("png", "pdf")):
        self.notebook = notebook
        self.dir = Path(figures_dir) / notebook
        self.dir.mkdir(parents=True, exist_ok=True)
        self.quick = bool(quick)
        self.seed = int(seed)
        self.formats = tuple(formats)
        self.metrics: dict[str, dict] = {}
        self.claims: list[Claim] = []
        self.files: list[str] = []

    def savefig(self, fig, name: str, close: bool = True):
        """Save ``fig`` as ``<name>.png`` (and the other formats) in the notebook's folder."""
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
        if close:
            plt.close(fig)
        return self.dir / f"{name}.png"

    def metric(self, name: str, value, unit: str = "", note: str = ""):
        self.metrics[name] = {"value": _jsonable(value), "unit": unit, "note": note}
        return value

    def claim(self, paper: str, item: str, figure: str, metric: str, value, target: str,
              verdict: str, note: str = ""):
        """Record one paper figure/claim and how this reproduction compares with it."""
        if verdict not in VERDICTS:
            raise ValueError(f"verdict must be one of {VERDICTS}, got {verdict!r}")
        self.claims.append(Claim(paper, item, figure, metric, _jsonable(value), target,
                                 verdict, note))

    def write(self) -> Path:
        path = self.dir / "metrics.json"
        doc = {"notebook": self.notebook, "quick": self.quick, "seed": self.seed,
               "metrics": self.metrics, "claims": [c.__dict__ for c in self.claims],
               "files": sorted(self.files + ["metrics.json"])}
        path.write_text(json.dumps(_jsonable(doc), indent=1, sort_keys=False) + "\n")
        return path


def load_metrics(path) -> dict:
    """Read a metrics.json; returns ``{name: value}`` plus the raw document as ``_doc``."""
    doc = json.loads(Path(path).read_text())
    out = {k: v["value"] for k, v in doc["metrics"].items()}
    out["_doc"] = doc
    return out
