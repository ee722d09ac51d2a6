"""One JupyterLab server for every test in ``tests/lab/`` (started by ``make lab``, stopped by
its process id), serving quick-mode copies of the notebooks from a temporary folder."""

from __future__ import annotations

import pytest
from labkit import parameterised_copies, start_lab, stop
from vehicle_observers.results import pipeline

NOTEBOOKS = [p.stem for p in pipeline.notebooks(kinds=("lesson",))]   # what a student opens


@pytest.fixture(scope="session")
def lab(tmp_path_factory):
    """``(Lab, figures_dir)``: the server and where the notebooks it runs write their figures."""
    work = tmp_path_factory.mktemp("lab")
    figures = work / "figures"
    parameterised_copies(NOTEBOOKS, work / "notebooks", figures)
    server = start_lab(work / "notebooks", work)
    try:
        yield server, figures
    finally:
        stop(server.proc)
