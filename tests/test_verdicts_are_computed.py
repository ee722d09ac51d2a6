"""No verdict is written by hand: every claim's verdict comes from its Rule.

A verdict word ("reproduced", "partly", "differs", "not comparable") may appear as a string
literal only in the reporting layer that computes verdicts (``results/``); anywhere else in
``lib/`` or in a notebook's code it would be a hand-written verdict, and so would a ``verdict=``
argument or a bold verdict in a notebook's markdown. The last test plants each form and checks
that it is caught.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import nbformat
from vehicle_observers.data.logs import repo_root
from vehicle_observers.results.rules import VERDICTS

ROOT = repo_root()
ALLOWED = ROOT / "lib" / "vehicle_observers" / "results"
MD_VERDICT = re.compile(r"\*\*\s*(claim\s+)?(" + "|".join(VERDICTS) + r")\b", re.I)


def literal_verdicts(source: str, where: str) -> list[str]:
    """Hand-written verdicts in Python ``source``: verdict-word string constants and
    ``verdict=`` keyword arguments."""
    out = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            if node.value.strip().lower() in VERDICTS:
                out.append(f"{where}:{node.lineno}: literal {node.value!r}")
        elif isinstance(node, ast.keyword) and node.arg == "verdict":
            out.append(f"{where}:{node.value.lineno}: verdict= argument")
    return out


def markdown_verdicts(text: str, where: str) -> list[str]:
    return [f"{where}: bold verdict {m.group(0)!r} in markdown" for m in MD_VERDICT.finditer(text)]


def scan(lib: Path, notebooks: Path, allowed: Path) -> list[str]:
    bad = []
    for f in sorted(lib.rglob("*.py")):
        if allowed in f.parents:
            continue
        bad += literal_verdicts(f.read_text(), str(f.relative_to(lib.parent)))
    for nb in sorted(notebooks.glob("*.ipynb")):
        doc = nbformat.read(str(nb), as_version=4)
        for i, c in enumerate(doc.cells):
            if c.cell_type == "code":
                src = "\n".join(ln for ln in c.source.splitlines() if not ln.lstrip().startswith(("%", "!")))
                bad += literal_verdicts(src, f"{nb.name} cell {i}")
            elif c.cell_type == "markdown":
                bad += markdown_verdicts(c.source, f"{nb.name} cell {i}")
    return bad


def test_no_hand_written_verdicts():
    bad = scan(ROOT / "lib", ROOT / "notebooks", ALLOWED)
    assert not bad, "hand-written verdicts (use a Rule):\n" + "\n".join(bad)


def test_planted_hand_written_verdicts_are_caught(tmp_path):
    lib, nbs = tmp_path / "lib", tmp_path / "notebooks"
    (lib / "pkg").mkdir(parents=True)
    nbs.mkdir()
    (lib / "pkg" / "study.py").write_text(
        "def claims(m):\n    return 'reproduced' if m < 1 else 'differs'\n")
    (lib / "pkg" / "other.py").write_text("def f(rep, v):\n    rep.claim('P', 'i', '', 'm', v, verdict=v)\n")
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell("v = 'Partly'"),
                                         nbformat.v4.new_markdown_cell("**Claim reproduced.** yes")])
    nbformat.write(nb, str(nbs / "01_x.ipynb"))
    bad = scan(lib, nbs, tmp_path / "allowed")
    assert len(bad) == 5, bad
    assert sum("literal" in b for b in bad) == 3
    assert any("verdict= argument" in b for b in bad) and any("bold verdict" in b for b in bad)
