"""The package's layers: dependencies point one way and there is no import cycle.

Layers, lowest first (a module may import only from lower layers or from its own subpackage):

    core  <-  models  <-  design, data  <-  observers, results  <-  baselines  <-  estimation
          <-  campaign  <-  cli  <-  bench

The reproductions (``lib/vehicle_observers_papers``) sit beside the library: they import it,
and the library never imports them (nor any other package of this repository but itself).

Every ``import`` counts, including those inside functions (a lazy import is still a
dependency). The checker reads the sources with ``ast``; the last tests plant a reverse import
and a cycle in a copy of the package and check that both are caught.
"""

from __future__ import annotations

import ast
import shutil
from pathlib import Path

import pytest
from vehicle_observers.data.logs import repo_root

PKG = "vehicle_observers"
SRC = repo_root() / "lib" / PKG
LAYER = {"core": 0, "models": 1, "design": 2, "data": 2, "observers": 3, "results": 3,
         "baselines": 4, "estimation": 5, "campaign": 6, "cli": 7, "bench": 8}
#: packages of this repository the library must never import
BESIDE = ("vehicle_observers_papers",)
ROOT_MODULES = {"__init__": 0.5, "__main__": 9}  # the root re-exports core errors; __main__ runs cli


def module_name(path: Path, src: Path) -> str:
    parts = list(path.relative_to(src).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join([PKG, *parts])


def foreign_imports(src: Path) -> list[str]:
    """Every import (module level or inside a function) of a package in :data:`BESIDE`
    by a library module, as ``file:line: module``."""
    bad = []
    for f in sorted(src.rglob("*.py")):
        for node in ast.walk(ast.parse(f.read_text(), filename=str(f))):
            mods = []
            if isinstance(node, ast.Import):
                mods = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level:
                mods = [node.module or ""]
            elif (isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(
                    node.func, "id", "")) in ("import_module", "__import__") and node.args
                  and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)):
                mods = [node.args[0].value]
            bad += [f"{f.relative_to(src.parent)}:{node.lineno}: {m}" for m in mods
                    if m.split(".")[0] in BESIDE]
    return bad


def imports_of(path: Path, name: str) -> list[tuple[int, str]]:
    """``(line, absolute module)`` for every import of the package in ``path``."""
    tree = ast.parse(path.read_text(), filename=str(path))
    is_pkg = path.name == "__init__.py"
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names if a.name.split(".")[0] == PKG]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".") if is_pkg else name.split(".")[:-1]
                base = base[: len(base) - (node.level - 1)]
                mod = ".".join([*base, node.module] if node.module else base)
            else:
                mod = node.module or ""
            if mod.split(".")[0] != PKG:
                continue
            # "from pkg.sub import module" imports the module itself
            for a in node.names:
                out.append((node.lineno, f"{mod}.{a.name}" if _is_module(f"{mod}.{a.name}", path)
                            else mod))
    return out


def _is_module(dotted: str, path: Path) -> bool:
    src = _src_of(path)
    rel = Path(*dotted.split(".")[1:])
    return (src / rel).with_suffix(".py").exists() or (src / rel / "__init__.py").exists()


def _src_of(path: Path) -> Path:
    p = path
    while p.name != PKG:
        p = p.parent
    return p


def layer_of(mod: str) -> tuple[str, int]:
    parts = mod.split(".")
    if len(parts) == 1:
        return "__init__", ROOT_MODULES["__init__"]
    top = parts[1]
    if top in ROOT_MODULES:
        return top, ROOT_MODULES[top]
    if top not in LAYER:
        raise AssertionError(f"{mod}: subpackage {top!r} has no layer; add it to LAYER")
    return top, LAYER[top]


def graph(src: Path) -> dict[str, list[tuple[int, str, Path]]]:
    g = {}
    for f in sorted(src.rglob("*.py")):
        name = module_name(f, src)
        g[name] = [(ln, m, f) for ln, m in imports_of(f, name)]
    return g


def direction_violations(src: Path) -> list[str]:
    bad = []
    for name, deps in graph(src).items():
        top, rank = layer_of(name)
        for ln, dep, f in deps:
            dtop, drank = layer_of(dep)
            if dtop == top:
                continue
            if not drank < rank:
                bad.append(f"{f.relative_to(src.parent)}:{ln}: {top} (layer {rank}) imports "
                           f"{dep} ({dtop}, layer {drank}) against the direction")
    return sorted(set(bad))


def cycles(src: Path) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    g = {n: sorted({d for _, d, _ in deps if d != n}) for n, deps in graph(src).items()}
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in g.get(v, ()):
            if w not in g:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in g:
        if v not in index:
            visit(v)
    return out


def test_every_subpackage_has_a_layer_and_a_one_line_docstring():
    subs = sorted(p.parent.name for p in SRC.glob("*/__init__.py"))
    assert set(subs) == set(LAYER), f"subpackages {subs} vs layers {sorted(LAYER)}"
    for s in subs:
        doc = ast.get_docstring(ast.parse((SRC / s / "__init__.py").read_text()))
        assert doc and len(doc.splitlines()) == 1, f"{s}/__init__.py needs a one-line docstring"


def test_no_modules_left_at_the_top_level():
    top = sorted(p.stem for p in SRC.glob("*.py"))
    assert top == ["__init__", "__main__"], f"modules outside the concept subpackages: {top}"


def test_imports_point_one_way():
    bad = direction_violations(SRC)
    assert not bad, "imports against the layer direction:\n" + "\n".join(bad)


def test_the_library_never_imports_the_reproductions():
    bad = foreign_imports(SRC)
    assert not bad, "the library imports the reproductions:\n" + "\n".join(bad)


def test_the_reproductions_are_a_package_beside_the_library():
    papers = SRC.parent / BESIDE[0]
    folders = sorted(p.parent.name for p in papers.glob("*/__init__.py"))
    assert folders, "no reproduction folders"
    import re
    for f in folders:   # one folder per paper, <author>_<year>, the studies of notebooks 07-08
        # and the course layer of notebook 00
        assert re.fullmatch(r"[a-z]+_(19|20)\d\d", f) or f in ("benchmark_study",
                                                               "robustness_study", "course"), f
    assert not (SRC / "papers").exists(), "paper code inside the library"


def test_no_import_cycle():
    cyc = cycles(SRC)
    assert not cyc, f"import cycles: {cyc}"


@pytest.fixture
def package_copy(tmp_path):
    dst = tmp_path / PKG
    shutil.copytree(SRC, dst, ignore=shutil.ignore_patterns("__pycache__"))
    return dst


def test_a_planted_reverse_import_is_caught(package_copy):
    tires = package_copy / "models" / "tires.py"
    tires.write_text(tires.read_text() + "\n\ndef _planted():\n"
                     "    from vehicle_observers.observers import dmvt  # noqa\n")
    bad = direction_violations(package_copy)
    assert len(bad) == 1
    assert "models/tires.py" in bad[0] and "vehicle_observers.observers.dmvt" in bad[0]


@pytest.mark.parametrize("line", [
    "from vehicle_observers_papers.ifqir_2017 import constants  # noqa",
    "    import vehicle_observers_papers.rabhi_2004.constants  # noqa",
    "    importlib.import_module('vehicle_observers_papers.yacine_2015.constants')",
])
def test_a_planted_import_of_the_reproductions_is_caught(package_copy, line):
    mod = package_copy / "observers" / "dmvt.py"
    body = line if not line.startswith(" ") else "def _planted():\n" + line
    mod.write_text(mod.read_text() + "\n\nimport importlib  # noqa\n" + body + "\n")
    bad = foreign_imports(package_copy)
    assert len(bad) == 1 and "observers/dmvt.py" in bad[0] and "vehicle_observers_papers" in bad[0]


def test_a_planted_cycle_is_caught(package_copy):
    a, b = package_copy / "core" / "metrics.py", package_copy / "core" / "signals.py"
    a.write_text(a.read_text() + "\nfrom vehicle_observers.core import signals  # noqa\n")
    b.write_text(b.read_text() + "\nfrom vehicle_observers.core import metrics  # noqa\n")
    assert cycles(package_copy) == [["vehicle_observers.core.metrics",
                                     "vehicle_observers.core.signals"]]
