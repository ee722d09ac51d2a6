"""Repository hygiene: notebooks stored clean with a papermill parameters cell, every notebook
executed by a test, every file in figures/ produced by a notebook."""

import ast
import json
import re
from pathlib import Path

import nbformat
import pytest
from nbformat.v4 import new_code_cell, new_notebook
from vehicle_observers.data.logs import repo_root
from vehicle_observers.results import pipeline

ROOT = repo_root()
#: every notebook: lessons, reproduction reports and solutions
NOTEBOOKS = pipeline.notebooks(ROOT, kinds=tuple(pipeline.NOTEBOOK_KINDS))
LESSONS = pipeline.notebooks(ROOT, kinds=("lesson",))
PRODUCERS_OUTSIDE_NOTEBOOKS: set = set()  # make bench writes build/benchmark/ (ignored by git)


def write_notebook(path, cells):
    """A notebook of ``(kind, source)`` cells (``kind``: ``code`` or ``params``) for the
    pipeline tests, with the project's kernel."""
    nb = new_notebook()
    nb.metadata["kernelspec"] = {"name": "vehicle-observers", "display_name":
                                 "Python (vehicle-observers)", "language": "python"}
    for i, (kind, src) in enumerate(cells):
        c = new_code_cell(src)
        if kind == "params":
            c.metadata["tags"] = ["parameters"]
        c["id"] = f"cell-{i:02d}"
        nb.cells.append(c)
    nbformat.write(nb, str(path))
    return path


def test_there_are_notebooks():
    assert NOTEBOOKS, "no notebooks found"


@pytest.mark.parametrize("nb", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_stored_without_outputs_and_has_parameters(nb):
    doc = nbformat.read(str(nb), as_version=4)
    nbformat.validate(doc)
    for i, c in enumerate(doc.cells):
        if c.cell_type == "code":
            assert not c.outputs, f"{nb.name} cell {i} has stored outputs"
            assert c.execution_count is None, f"{nb.name} cell {i} has an execution count"
    params = [c for c in doc.cells if "parameters" in c.metadata.get("tags", [])]
    assert len(params) == 1, f"{nb.name}: need exactly one cell tagged 'parameters'"
    for name in ("seed", "quick", "figures_dir"):
        assert re.search(rf"^{name}\s*=", params[0].source, re.M), f"{nb.name}: no {name!r}"


#: longest code cell a notebook may have: cells call the library (experiments, figures and
#: metric tables live in ``vehicle_observers_papers``); a claim with its prose is the longest
MAX_CODE_CELL_LINES = 20


def _nested_loops(source: str) -> bool:
    """True if a ``for``/``while`` statement or a comprehension with several ``for`` clauses
    contains another loop (IPython magics and shell lines are skipped)."""
    code = "\n".join("" if ln.lstrip().startswith(("%", "!")) else ln for ln in source.splitlines())
    loops = (ast.For, ast.While, ast.AsyncFor)
    for node in ast.walk(ast.parse(code)):
        if isinstance(node, loops) and any(isinstance(n, loops + (ast.comprehension,))
                                           for child in node.body + node.orelse
                                           for n in ast.walk(child)):
            return True
        if isinstance(node, (ast.ListComp, ast.SetComp, ast.DictComp, ast.GeneratorExp)) \
                and len(node.generators) > 1:
            return True
    return False


def test_nested_loop_detector():
    assert _nested_loops("for a in x:\n    for b in y:\n        pass")
    assert _nested_loops("for a in x:\n    s = [b for b in a]")
    assert _nested_loops("z = [a * b for a in x for b in y]")
    assert not _nested_loops("for a in x:\n    pass\n\nfor b in y:\n    pass")
    assert not _nested_loops("%matplotlib inline\nz = [a for a in x]")


@pytest.mark.parametrize("nb", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_code_cells_are_thin(nb):
    doc = nbformat.read(str(nb), as_version=4)
    for i, c in enumerate(doc.cells):
        if c.cell_type != "code":
            continue
        n = len(c.source.splitlines())
        assert n <= MAX_CODE_CELL_LINES, (
            f"{nb.name} cell {i}: {n} lines of code (at most {MAX_CODE_CELL_LINES}); move the "
            "logic into the library with a unit test")
        assert not _nested_loops(c.source), f"{nb.name} cell {i}: nested loops belong in the library"


@pytest.mark.parametrize("nb", [nb for nb in NOTEBOOKS if pipeline.notebook_kind(nb) != "solutions"],
                         ids=lambda p: p.stem)
def test_every_notebook_is_executed_by_a_test(nb):
    """A lesson and a report each have a test that runs them (solutions are run by
    ``tests/test_executed_notebooks.py``, which checks every checker says ``correct``)."""
    num = nb.stem[:2]
    t = ROOT / "tests" / "notebooks" / f"test_notebook_{num}.py"
    assert t.exists(), f"no tests/test_notebook_{num}.py for {nb.name}"
    text = t.read_text()
    assert f'"{nb.stem}"' in text and "run_notebook(" in text, f"{t.name} does not run {nb.stem}"


def test_every_figure_file_is_produced_by_a_notebook():
    sections = {pipeline.section_of(nb.stem) for nb in NOTEBOOKS} | PRODUCERS_OUTSIDE_NOTEBOOKS
    figs = ROOT / "figures"
    for folder in sorted(p for p in figs.iterdir() if p.is_dir()):
        assert folder.name in sections, f"figures/{folder.name} has no producing notebook"
        mj = folder / "metrics.json"
        assert mj.exists(), f"figures/{folder.name} has no metrics.json"
        doc = json.loads(mj.read_text())
        listed = set(doc["files"])
        present = {p.name for p in folder.iterdir() if p.is_file()}
        assert present == listed, (f"figures/{folder.name}: files not written by its producer: "
                                   f"{sorted(present - listed)}; missing: {sorted(listed - present)}")
        assert not doc["quick"], f"figures/{folder.name} was generated in quick mode"
        extra = [p.name for p in folder.iterdir() if p.is_dir() and p.name != "lesson"]
        assert not extra, f"figures/{folder.name}: folders not written by a notebook: {extra}"
        lesson = folder / "lesson"
        if lesson.is_dir():   # the lesson's figures: each one named in its figure_data.json
            names = set(json.loads((lesson / "figure_data.json").read_text()))
            present = {p.name for p in lesson.iterdir()}
            assert present == {f"{n}.png" for n in names} | {"figure_data.json"}, (
                f"figures/{folder.name}/lesson: {sorted(present)} against figures {sorted(names)}")
    stray = [p.name for p in figs.iterdir() if p.is_file()]
    assert not stray, f"files directly in figures/: {stray}"


@pytest.mark.parametrize("nb", LESSONS, ids=lambda p: p.stem)
def test_every_lesson_has_a_report_solutions_and_a_reproduction_entry(nb):
    """A section is three notebooks (``pipeline.NOTEBOOK_KINDS``): the lesson, the reproduction
    report that writes ``figures/<section>/metrics.json`` (listed in REPRODUCTION.md), and the
    worked solutions of the lesson's exercises."""
    text = (ROOT / "REPRODUCTION.md").read_text()
    for kind in ("report", "solutions"):
        p = pipeline.notebook_path(f"{nb.stem}_{kind}", ROOT)
        assert p.exists(), f"{nb.stem}: no {kind} notebook {p.relative_to(ROOT)}"
    assert (ROOT / "figures" / nb.stem / "metrics.json").exists(), f"run make figures ({nb.stem})"
    assert f"## {nb.stem}" in text, f"REPRODUCTION.md has no section for {nb.stem}"
    assert f"notebooks/reports/{nb.stem}_report.ipynb" in text


def test_pipeline_reports_failing_notebook_and_cell(tmp_path, monkeypatch, capsys):
    nb = tmp_path / "99_broken.ipynb"
    write_notebook(nb, [("params", "seed = 0\nquick = False\nfigures_dir = '.'"),
                        ("code", "x = 1"), ("code", "raise ValueError('boom at purpose')")])
    monkeypatch.setattr(pipeline, "notebooks", lambda root=None: [nb])
    rc = pipeline.main(["--figures", str(tmp_path / "f"), "--build", str(tmp_path / "b"),
                        "--quick"])
    err = capsys.readouterr().err
    assert rc == 1
    assert "99_broken.ipynb" in err and "ValueError" in err and "boom at purpose" in err
    assert re.search(r"cell \d", err)
    assert (tmp_path / "b" / "99_broken.ipynb").exists()  # executed copy kept


def test_pipeline_runs_notebooks_in_parallel_and_reports_each_failure(tmp_path, monkeypatch, capsys):
    good = write_notebook(tmp_path / "01_good.ipynb", [
        ("params", "seed = 0\nquick = False\nfigures_dir = '.'"),
        ("code", "from pathlib import Path\np = Path(figures_dir) / 'good'\np.mkdir(parents=True)\n"
                 "(p / 'seed.txt').write_text(str(seed))")])
    bad = write_notebook(tmp_path / "02_bad.ipynb", [
        ("params", "seed = 0\nquick = False\nfigures_dir = '.'"), ("code", "1 / 0")])
    monkeypatch.setattr(pipeline, "notebooks", lambda root=None: [good, bad])
    rc = pipeline.main(["--figures", str(tmp_path / "f"), "--build", str(tmp_path / "b"),
                        "--quick", "--seed", "7", "--jobs", "2"])
    out = capsys.readouterr()
    assert rc == 1
    assert "02_bad.ipynb" in out.err and "ZeroDivisionError" in out.err and "01_good" not in out.err
    assert (tmp_path / "f" / "good" / "seed.txt").read_text() == "7"   # the other one still ran
    assert pipeline.main(["--jobs", "0"]) == 2


#: what the opening cells of every lesson tell a student (the course's learning path)
LESSON_HEAD = ("what you will learn", "prerequisites", "reading time", "run time")
#: the reproduction's bookkeeping, which lives in the reports (``notebooks/reports/``), never in
#: a lesson: recording metrics, claims, rules, timings, printing library source
BOOKKEEPING = re.compile(r"\bReport\(|\brep\.|\bRule[.(]|\.claim\(|\.metric\(|\.record\(|"
                         r"\.timing\(|\bgetsource\b|\bverdict|\bmake (?:check|bench)\b|"
                         r"\brtol\b|regeneration check")
#: a lesson of a paper section builds its observer in a cell: a function whose name says it is
#: the observer's step / right-hand side / update (00, the start page, has no observer)
OBSERVER_DEF = re.compile(r"^def \w*(?:step|rhs|update|predict|observer|estimat)\w*\(", re.M)


def lesson_problems(doc: nbformat.NotebookNode, name: str) -> list[str]:
    """What keeps a stored lesson from teaching alone: the learning-path head missing, the
    reproduction's bookkeeping in a cell (code or prose), no observer built in a cell."""
    out = []
    md = [c.source for c in doc.cells if c.cell_type == "markdown"]
    head = " ".join(md[:3]).lower()
    missing = [p for p in LESSON_HEAD if p not in head]
    if missing:
        out.append(f"the opening cells do not say: {', '.join(missing)}")
    if "symbol" not in head and "notation" not in head:
        out.append("no symbol / notation table at the top")
    for i, c in enumerate(doc.cells):
        m = BOOKKEEPING.search(c.source)
        if m:
            out.append(f"cell {i} ({c.cell_type}): reproduction bookkeeping {m.group(0)!r} "
                       "(it belongs in the section's report)")
    code = "\n".join(c.source for c in doc.cells if c.cell_type == "code"
                     and "exercise" not in c.metadata.get("tags", []))
    # 00 (the start page) and 01 (exact TS models: the model is built in cells, the observers
    # come from 02 on) have no observer to build
    if not name.startswith(("00", "01")) and not OBSERVER_DEF.search(code):
        out.append("no cell defines the observer's step (def ...step/rhs/update/predict...)")
    return out


@pytest.mark.parametrize("nb", LESSONS, ids=lambda p: p.stem)
def test_lesson_teaches_without_the_reproduction_bookkeeping(nb):
    """A lesson opens with its learning path and notation, builds its observer in a cell, and
    holds no metric, claim, rule, verdict, tolerance or printed library source."""
    problems = lesson_problems(nbformat.read(str(nb), as_version=4), nb.stem)
    assert not problems, f"{nb.name}: " + "; ".join(problems)


def test_lesson_check_catches_bookkeeping_and_a_printed_observer():
    """Catches the lesson check passing a notebook that records claims or prints source."""
    from nbformat.v4 import new_markdown_cell

    head = new_markdown_cell("# 09\n**What you will learn** ... **Prerequisites** ... reading time "
                             "5 min, run time 1 min. **Symbols** ...")
    good = new_notebook(cells=[head, new_code_cell("def observer_step(x, y):\n    return x")])
    assert lesson_problems(good, "09_x") == []
    bad = new_notebook(cells=[head, new_code_cell("print(inspect.getsource(iv.rhs))"),
                              new_code_cell("rep.claim('P', 'Fig. 1', '', 'm', Rule('m'))")])
    problems = lesson_problems(bad, "09_x")
    assert any("'getsource'" in p for p in problems)
    assert any("'rep.'" in p for p in problems)
    assert any("observer's step" in p for p in problems)


@pytest.mark.parametrize("nb", pipeline.notebooks(ROOT, kinds=("report",)), ids=lambda p: p.stem)
def test_report_names_its_lesson_and_writes_its_section(nb):
    """A report says which lesson it reports on and records into the section's folder (the
    ``Report("<section>", ...)`` whose metrics.json make check compares)."""
    doc = nbformat.read(str(nb), as_version=4)
    section = pipeline.section_of(nb.stem)
    text = "\n".join(c.source for c in doc.cells)
    assert f"{section}.ipynb" in text, f"{nb.name} does not name its lesson {section}.ipynb"
    assert f'Report("{section}"' in text, f"{nb.name} does not record into figures/{section}/"


def _own_kernel(args):
    """Worker of the test below: run a one-cell notebook, return what its kernel printed."""
    i, tmp = args
    nb = write_notebook(Path(tmp) / f"k{i}.ipynb", [
        ("params", "seed = 0\nquick = True\nfigures_dir = None"), ("code", f"print({i})")])
    pipeline.run_notebook(nb, Path(tmp) / f"k{i}_out.ipynb", Path(tmp) / "f")
    return nbformat.read(str(Path(tmp) / f"k{i}_out.ipynb"), as_version=4).cells[-1].outputs[0].text


def test_kernels_started_together_each_answer_their_own_client(tmp_path):
    """Four notebooks started at once in four processes (as the pipeline's --jobs and the test
    workers do) each get their own kernel's answer: the kernels talk over socket files with a
    random prefix (``pipeline.ipc_kernel_manager``), which cannot collide as TCP ports can."""
    from concurrent.futures import ProcessPoolExecutor
    from multiprocessing import get_context

    with ProcessPoolExecutor(4, mp_context=get_context("spawn")) as ex:
        out = list(ex.map(_own_kernel, [(i, str(tmp_path)) for i in range(4)]))
    assert [o.strip() for o in out] == ["0", "1", "2", "3"]
    assert pipeline.ipc_kernel_manager()().transport == "ipc"
