"""Executed notebooks show what they save.

Every executed notebook (papermill, quick and full mode) holds at least one image output per
figure it saves (the ``.png`` files listed in its ``metrics.json`` "files") and no output that is
a bare path (``PosixPath('.../fig.png')``) or a numpy scalar repr (``np.float64(0.28)``).

- quick mode: the copies the notebook tests execute (``run_notebook`` in ``conftest.py``, shared
  per test session, so each notebook runs once);
- full mode: the copies of the last ``make figures`` / ``make html`` in ``build/notebooks/``,
  against the committed ``figures/<notebook>/metrics.json``; skipped with the reason when there
  is no copy or it was executed from an older version of the notebook.

The checker itself is tested on small synthetic notebooks (one that saves a figure without
showing it must fail).
"""

from __future__ import annotations

import base64
import json
import re
from pathlib import Path

import nbformat
import pytest
from nbformat.v4 import new_code_cell, new_notebook, new_output
from vehicle_observers.data.logs import repo_root
from vehicle_observers.results import pipeline

ROOT = repo_root()
NOTEBOOKS = [p.stem for p in pipeline.notebooks(ROOT)]
FULL_BUILD = ROOT / "build" / "notebooks"

#: an output that is a path object or a lone file path
_PATH_RE = re.compile(r"^(?:(?:Posix|Windows|Pure\w*)?Path\(.*\)|'?(?:[\w.~-]*/)+[\w.-]+\.\w{2,4}'?)$")
#: a numpy scalar repr (numpy >= 2 prints ``np.float64(0.28)``)
_NP_SCALAR_RE = re.compile(r"\bnp\.(?:float|int|uint|complex|bool|longdouble|str_)\w*\(")

#: notebooks that fail the check today: {(notebook, mode): reason}; strict, so an entry must go
#: as soon as its notebook is fixed
_KNOWN: dict[str, str] = {}
KNOWN_FAILURES: dict[tuple[str, str], str] = {
    (nb, mode): f"{nb}: {why}" for nb, why in _KNOWN.items() for mode in ("quick", "full")}


def saved_figures(metrics_json: Path) -> list[str]:
    """Figure names (PNG files without extension) a notebook's ``metrics.json`` lists."""
    files = json.loads(Path(metrics_json).read_text())["files"]
    return sorted(f[:-4] for f in files if f.endswith(".png"))


def _text(out, key="text/plain") -> str:
    if out.output_type == "stream":
        return "".join(out.text)
    v = out.get("data", {}).get(key, "")
    return "".join(v) if isinstance(v, list) else v


def output_problems(nb: nbformat.NotebookNode, figures: list[str],
                    figures_dir: Path | None = None) -> list[str]:
    """What an executed notebook does wrong, as one line per problem (empty when fine).

    ``figures``: names of the PNG figures the run saved; the notebook must hold at least as many
    ``image/png`` outputs. With ``figures_dir`` the message names the saved figures whose bytes
    appear in no image output."""
    problems, images = [], []
    for i, cell in enumerate(nb.cells):
        if cell.cell_type != "code":
            continue
        for out in cell.get("outputs", []):
            if out.output_type == "error":
                problems.append(f"cell {i}: error output {out.ename}: {out.evalue}")
                continue
            if "image/png" in out.get("data", {}):
                images.append(out.data["image/png"])
            rich = {"text/html", "image/png", "text/markdown", "text/latex"} & set(out.get("data", {}))
            text = _text(out).strip()
            if not text or (rich and out.output_type != "stream"):
                continue
            if _NP_SCALAR_RE.search(text):
                problems.append(f"cell {i}: numpy scalar repr in the output: {text[:80]!r}")
            elif out.output_type != "stream" and _PATH_RE.match(text):
                problems.append(f"cell {i}: output is a bare path: {text[:80]!r}")
            elif out.output_type == "stream" and _PATH_RE.match(text) and "\n" not in text:
                problems.append(f"cell {i}: printed a bare path: {text[:80]!r}")
    if len(images) < len(figures):
        msg = f"{len(images)} image outputs for {len(figures)} saved figures"
        if figures_dir is not None:
            shown = {"".join(b).replace("\n", "") for b in images}
            missing = [f for f in figures if (Path(figures_dir) / f"{f}.png").exists() and
                       base64.b64encode((Path(figures_dir) / f"{f}.png").read_bytes()).decode()
                       not in shown]
            msg += f"; not shown: {', '.join(missing) or '(cannot tell)'}"
        problems.append(msg)
    return problems


def code_sources(nb: nbformat.NotebookNode) -> list[str]:
    """Code cell sources without papermill's injected parameters (to compare versions)."""
    return [c.source for c in nb.cells if c.cell_type == "code"
            and "injected-parameters" not in c.metadata.get("tags", [])]


def _param(name: str, mode: str):
    marks = [pytest.mark.xdist_group(f"nb{name[:2]}")] if mode == "quick" else []
    if (name, mode) in KNOWN_FAILURES:
        marks.append(pytest.mark.xfail(strict=True, reason=KNOWN_FAILURES[(name, mode)]))
    return pytest.param(name, marks=marks, id=name)


# ---------------------------------------------------------------- the checker itself ----------

def _png_bytes(fig_dir: Path, name: str, slope: float = 1.0) -> bytes:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(2, 1))
    ax.plot([0, 1], [0, slope])
    fig.savefig(fig_dir / f"{name}.png")
    plt.close(fig)
    return (fig_dir / f"{name}.png").read_bytes()


def _executed(outputs: list) -> nbformat.NotebookNode:
    nb = new_notebook()
    for i, outs in enumerate(outputs):
        c = new_code_cell("x", execution_count=i + 1)
        c.outputs = outs
        nb.cells.append(c)
    return nb


def test_checker_accepts_a_notebook_that_shows_its_figure(tmp_path):
    png = base64.b64encode(_png_bytes(tmp_path, "fig1")).decode()
    nb = _executed([[new_output("display_data", data={"image/png": png, "text/plain": "<Image>"})],
                    [new_output("execute_result", data={"text/html": "<table></table>",
                                                        "text/plain": "np.float64(1.0)"},
                                execution_count=2)]])
    assert output_problems(nb, ["fig1"], tmp_path) == []


def test_checker_rejects_a_saved_but_not_shown_figure(tmp_path):
    _png_bytes(tmp_path, "fig1")
    png = base64.b64encode(_png_bytes(tmp_path, "other", slope=-1.0)).decode()
    nb = _executed([[new_output("display_data", data={"image/png": png})]])
    assert output_problems(nb, ["fig1"], tmp_path) == []  # one image for one figure: count holds
    problems = output_problems(nb, ["fig1", "fig2"], tmp_path)
    assert problems == ["1 image outputs for 2 saved figures; not shown: fig1"]


@pytest.mark.parametrize("text, kind", [
    ("PosixPath('/repo/figures/02_premise_estimation/fig2.png')", "bare path"),
    ("'../figures/01_ts_exactness/fig1.png'", "bare path"),
    ("np.float64(2.8921737574951814)", "numpy scalar"),
    ("{'rmse': np.float64(0.1), 'n': 3}", "numpy scalar"),
])
def test_checker_rejects_path_and_numpy_reprs(text, kind):
    nb = _executed([[new_output("execute_result", data={"text/plain": text}, execution_count=1)]])
    (problem,) = output_problems(nb, [])
    assert kind in problem and "cell 0" in problem


def test_checker_rejects_a_printed_path_and_an_error_but_not_prose():
    nb = _executed([[new_output("stream", name="stdout", text="figures/x/fig1.png\n")],
                    [new_output("error", ename="ValueError", evalue="bad", traceback=[])],
                    [new_output("stream", name="stdout", text="RMSE of v_y: 0.28 m/s\n")],
                    [new_output("execute_result", data={"text/plain": "0.28"}, execution_count=4)]])
    assert output_problems(nb, []) == ["cell 0: printed a bare path: 'figures/x/fig1.png'",
                                       "cell 1: error output ValueError: bad"]


# ---------------------------------------------------------------- the notebooks ---------------

@pytest.mark.notebook
@pytest.mark.parametrize("name", [_param(n, "quick") for n in NOTEBOOKS])
def test_quick_executed_notebook_shows_its_figures(name, run_notebook):
    m = run_notebook(name)
    nb = nbformat.read(str(m["_executed"]), as_version=4)
    figures = saved_figures(m["_dir"] / "metrics.json")
    problems = output_problems(nb, figures, m["_dir"])
    assert not problems, f"{name} (quick): " + "; ".join(problems)


@pytest.mark.parametrize("name", [_param(n, "full") for n in NOTEBOOKS])
def test_full_executed_notebook_shows_its_figures(name):
    executed = FULL_BUILD / f"{name}.ipynb"
    if not executed.exists():
        pytest.skip("no full-mode executed copy in build/notebooks/ (run `make figures` or "
                    "`make html` first to check them)")
    nb = nbformat.read(str(executed), as_version=4)
    params = nb.metadata.get("papermill", {}).get("parameters", {})
    current = nbformat.read(str(ROOT / "notebooks" / f"{name}.ipynb"), as_version=4)
    if params.get("quick") or code_sources(nb) != code_sources(current):
        pytest.skip(f"{name}: build/notebooks/ copy is from another notebook version or quick "
                    "mode (run `make figures`)")
    fig_dir = Path(params.get("figures_dir") or ROOT / "figures") / name
    if not (fig_dir / "metrics.json").exists():
        fig_dir = ROOT / "figures" / name
    problems = output_problems(nb, saved_figures(fig_dir / "metrics.json"), fig_dir)
    assert not problems, f"{name} (full): " + "; ".join(problems)


# ---------------------------------------------------------------- HTML for lecturers ----------

def test_html_of_an_executed_notebook_embeds_its_figures(tmp_path):
    png = _png_bytes(tmp_path, "fig1")
    nb = _executed([[new_output("display_data", data={"image/png": base64.b64encode(png).decode()})]])
    nb.cells.insert(0, nbformat.v4.new_markdown_cell("# Observer $\\hat x$"))
    nbformat.write(nb, str(tmp_path / "01_demo.ipynb"))
    (out,) = pipeline.write_html([tmp_path / "01_demo.ipynb"], tmp_path / "html")
    assert out == tmp_path / "html" / "01_demo.html"
    html = out.read_text(encoding="utf-8")
    assert html.count(f"data:image/png;base64,{base64.b64encode(png).decode()}") == 1
    assert "Observer" in html and "<title>01_demo</title>" in html
    with pytest.raises(FileNotFoundError, match="02_missing.ipynb"):
        pipeline.write_html([tmp_path / "02_missing.ipynb"], tmp_path / "html")
