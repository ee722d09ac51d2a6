"""Every rule says where its threshold comes from, and every committed claim has a kind.

A :class:`Rule` with a threshold (a ``reproduced`` condition) in ``lib/`` or in a notebook's code
must pass ``source=`` ("paper: <quote or equation>" or "chosen here: <reason>"; a literal text is
checked here, a variable holding it through the committed results). In the committed
``figures/<notebook>/metrics.json`` every claim has a kind (``rules.KINDS``) and every rule with
a threshold a source. The last test plants each omission and checks that it is caught.
"""

from __future__ import annotations

import ast
import json
from pathlib import Path

import nbformat
from vehicle_observers.data.logs import repo_root
from vehicle_observers.results.rules import KINDS, SOURCE_PREFIXES

ROOT = repo_root()


def _text_start(node) -> str | None:
    """The literal start of a string expression (``None`` if it is not a literal)."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return node.value
    if isinstance(node, ast.JoinedStr) and node.values and isinstance(node.values[0], ast.Constant):
        return str(node.values[0].value)
    return None


def rules_without_source(source: str, where: str) -> list[str]:
    """``Rule(...)`` calls with a threshold but no ``source=``, or a literal source that
    starts with neither prefix."""
    out = []
    for node in ast.walk(ast.parse(source)):
        if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                and node.func.id == "Rule"):
            continue
        kw = {k.arg: k.value for k in node.keywords if k.arg}
        if "reproduced" not in kw and len(node.args) < 2:
            continue  # no threshold (Rule.no_number, or Rule(**rule_def) rebuilt from a file)
        if "source" not in kw:
            out.append(f"{where}:{node.lineno}: Rule with a threshold and no source=")
            continue
        start = _text_start(kw["source"])
        if start is not None and not start.startswith(SOURCE_PREFIXES):
            out.append(f"{where}:{node.lineno}: source {start[:40]!r} starts with neither "
                       f"{' nor '.join(SOURCE_PREFIXES)}")
    return out


def scan(lib: Path, notebooks: Path) -> list[str]:
    bad = []
    for f in sorted(lib.rglob("*.py")):
        bad += rules_without_source(f.read_text(), str(f.relative_to(lib.parent)))
    for nb in sorted(notebooks.glob("*.ipynb")):
        doc = nbformat.read(str(nb), as_version=4)
        for i, c in enumerate(doc.cells):
            if c.cell_type == "code":
                src = "\n".join(ln for ln in c.source.splitlines()
                                if not ln.lstrip().startswith(("%", "!")))
                bad += rules_without_source(src, f"{nb.name} cell {i}")
    return bad


def committed_claim_problems(figures: Path) -> list[str]:
    bad = []
    for mj in sorted(figures.glob("*/metrics.json")):
        doc = json.loads(mj.read_text())
        for c in doc.get("claims", []) if "notebook" in doc else []:
            what = f"{mj.parent.name}: {c['paper']}: {c['item']}"
            if c.get("kind") not in KINDS:
                bad.append(f"{what}: kind {c.get('kind')!r} not in {list(KINDS)}")
            rd = c.get("rule_def", {})
            if rd.get("reproduced") is not None and not str(rd.get("source", "")).startswith(
                    SOURCE_PREFIXES):
                bad.append(f"{what}: rule without a source ({rd.get('source', '')!r})")
    return bad


def test_every_rule_with_a_threshold_has_a_source():
    bad = scan(ROOT / "lib", ROOT / "notebooks")
    assert not bad, "rules without a source (Rule(..., source='paper: ...' or 'chosen here: ...')):\n" \
        + "\n".join(bad)


def test_committed_claims_have_a_kind_and_a_sourced_rule():
    bad = committed_claim_problems(ROOT / "figures")
    assert not bad, "regenerate with make figures:\n" + "\n".join(bad)


def test_planted_omissions_are_caught(tmp_path):
    lib, nbs, figs = tmp_path / "lib", tmp_path / "notebooks", tmp_path / "figures"
    (lib / "pkg").mkdir(parents=True)
    nbs.mkdir()
    (lib / "pkg" / "study.py").write_text(
        "def claims():\n"
        "    return [Rule('a', reproduced='value < 1'),\n"                      # no source
        "            Rule('a', 'value < 1', source='looks right'),\n"           # bad prefix
        "            Rule('a', reproduced='value < 1', source=f'paper: ({1})'),\n"  # fine
        "            Rule('a', reproduced='value < 1', source=SRC),\n"          # checked in results
        "            Rule.no_number('a', paper='none'), Rule(**{'value': 'a'})]\n")
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(
        "rep.claim('P', 'i', '', 'm', Rule('x', reproduced='value >= 0.98'))")])
    nbformat.write(nb, str(nbs / "01_x.ipynb"))
    bad = scan(lib, nbs)
    assert len(bad) == 3, bad
    assert sum("no source=" in b for b in bad) == 2 and sum("neither" in b for b in bad) == 1
    (figs / "01_x").mkdir(parents=True)
    claims = [{"paper": "P", "item": "a", "kind": "theory", "rule_def": {"value": "x"}},
              {"paper": "P", "item": "b", "kind": "paper",
               "rule_def": {"value": "x", "reproduced": "value < 1", "source": ""}},
              {"paper": "P", "item": "c", "kind": "target",
               "rule_def": {"value": "x", "reproduced": "value < 1", "source": "chosen here: x"}}]
    (figs / "01_x" / "metrics.json").write_text(json.dumps({"notebook": "01_x", "claims": claims}))
    bad = committed_claim_problems(figs)
    assert len(bad) == 2 and "kind 'theory'" in bad[0] and "without a source" in bad[1]
