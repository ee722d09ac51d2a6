"""``make lab`` as users start it: headless, as root in a container, on a port given in
``LAB_ARGS``; the project's kernel is offered and runs a notebook with inline figures.

The notebook (01, quick mode) runs through the server's REST API and the kernel websocket, as
the Lab front end does; its outputs are checked like the executed copies of the pipeline.
"""

from __future__ import annotations

import os
import subprocess
import sys

import nbformat
import pytest
from labkit import KERNEL, ROOT, run_in_kernel, saved_figures

pytestmark = [pytest.mark.xdist_group("lab"), pytest.mark.slow]
SHORT_NOTEBOOK = "01_ts_exactness"


def test_make_lab_command_line():
    """Extra arguments reach ``jupyter lab``; ``--allow-root`` only when run as root."""
    out = subprocess.run(["make", "-n", "--no-print-directory", "-o", ".venv/.installed", "lab",
                          "LAB_ARGS=--no-browser --port=8890"], cwd=ROOT, capture_output=True,
                         text=True, check=True, env={**os.environ, "MAKEFLAGS": ""}).stdout
    (line,) = [ln for ln in out.splitlines() if "jupyter lab" in ln]
    assert line.endswith("--no-browser --port=8890")
    assert "--notebook-dir=notebooks" in line
    assert ("--allow-root" in line) == (os.geteuid() == 0)


def test_make_sets_agg_only_for_headless_targets():
    db = subprocess.run(["make", "-p", "-n", "--no-print-directory", "-o", ".venv/.installed",
                         "lab"], cwd=ROOT, capture_output=True, text=True,
                        env={**os.environ, "MAKEFLAGS": ""}).stdout
    agg = sorted(ln.split(":")[0] for ln in db.splitlines() if ln.endswith("MPLBACKEND := Agg"))
    assert agg == ["bench", "check", "figures", "html", "test"]


def test_server_offers_the_project_kernel(lab):
    server, _ = lab
    specs = server.api("kernelspecs")["kernelspecs"]
    assert KERNEL in specs, f"kernels offered: {sorted(specs)}"
    argv = specs[KERNEL]["spec"]["argv"]
    assert os.path.abspath(argv[0]) == os.path.abspath(sys.executable), argv


def test_a_notebook_runs_through_the_server_with_inline_figures(lab):
    server, figures = lab
    nb = nbformat.read(str(server.root_dir / f"{SHORT_NOTEBOOK}.ipynb"), as_version=4)
    probe = "import matplotlib; print(matplotlib.get_backend())"
    sources = [probe] + [c.source for c in nb.cells if c.cell_type == "code"]
    kernel = server.api("kernels", "POST", {"name": KERNEL})
    try:
        outs = run_in_kernel(server, kernel["id"], sources)
    finally:
        server.api(f"kernels/{kernel['id']}", "DELETE")
    errors = [o for cell in outs for o in cell if o["output_type"] == "error"]
    assert not errors, f"{SHORT_NOTEBOOK}: {errors[0]['ename']}: {errors[0]['evalue']}"
    assert len(outs) == len(sources)
    # make lab leaves the backend to the kernel: inline, not the Agg of the headless targets
    assert outs[0][0]["text"].strip() == "module://matplotlib_inline.backend_inline"
    images = sum("image/png" in o.get("data", {}) for cell in outs for o in cell)
    figs = saved_figures(figures, SHORT_NOTEBOOK)
    assert figs, f"{SHORT_NOTEBOOK} saved no figure through the server"
    assert images >= len(figs), f"{images} image outputs for {len(figs)} figures {figs}"
