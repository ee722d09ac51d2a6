"""Shared fixtures. Notebook tests execute the notebook with papermill in quick mode into a
temporary folder and return its metrics (see ``run_notebook``)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import settings
from vehicle_observers.data.logs import repo_root
from vehicle_observers.results import pipeline
from vehicle_observers.results.reporting import load_metrics

ROOT = repo_root()
os.environ.setdefault("MPLBACKEND", "Agg")
# property tests draw their examples from a fixed seed: the same cases on every run and machine
settings.register_profile("deterministic", derandomize=True)
settings.load_profile("deterministic")


def execute_notebook(name: str, tmp_path: Path, seed: int = 0) -> dict:
    """Run ``notebooks/<name>.ipynb`` (quick mode) and return its metrics plus ``_dir`` (its
    figures) and ``_executed`` (the executed copy)."""
    from vehicle_observers.results.pipeline import run_notebook

    nb = pipeline.notebook_path(name, ROOT)
    assert nb.exists(), f"missing notebook {nb}"
    figs = tmp_path / "figures"
    run_notebook(nb, tmp_path / "build" / nb.name, figs, seed=seed, quick=True, timeout=300)
    section = pipeline.section_of(name)   # a report writes figures/<section>/metrics.json
    metrics = figs / section / "metrics.json"
    if pipeline.notebook_kind(nb) != "report" and not metrics.exists():
        # a lesson or solutions notebook records no metrics
        return {"_dir": figs / section, "_executed": tmp_path / "build" / nb.name}
    m = load_metrics(metrics)
    m["_dir"] = figs / section
    m["_executed"] = tmp_path / "build" / nb.name
    committed = ROOT / "figures" / section / "metrics.json"
    if committed.exists():  # quick mode must write the same files as the committed full run
        want = load_metrics(committed)["_doc"]["files"]
        got = m["_doc"]["files"]
        assert got == want, (f"{name}: quick run wrote {sorted(set(got) ^ set(want))} "
                             "differently from the committed figures/ (regenerate them)")
    return m


@pytest.fixture(scope="session")
def run_notebook(tmp_path_factory):
    """``run_notebook(name)`` -> metrics dict of a quick-mode execution (cached per test
    session, so the notebook tests and ``test_executed_notebooks.py`` share one run; with
    xdist both carry the notebook's ``xdist_group``). ``_executed``: the executed copy."""
    cache = {}

    def _run(name: str, seed: int = 0):
        if (name, seed) not in cache:
            cache[(name, seed)] = execute_notebook(name, tmp_path_factory.mktemp(name), seed)
        return cache[(name, seed)]

    return _run
