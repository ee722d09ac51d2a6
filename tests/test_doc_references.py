"""The package docstring and the README name only modules and files that exist."""

import importlib
import re
from pathlib import Path

import vehicle_observers

ROOT = Path(__file__).resolve().parents[1]


def test_package_docstring_names_existing_subpackages():
    """Catches a subpackage listed in ``vehicle_observers.__doc__`` (e.g. ``.papers``, moved
    out of the library) that cannot be imported."""
    names = re.findall(r":mod:`\.(\w+)`", vehicle_observers.__doc__)
    assert len(names) >= 8
    for n in names:
        importlib.import_module(f"vehicle_observers.{n}")


def test_readme_cites_existing_library_files():
    """Catches a README reference such as ``campaign/estimators.py`` to a library file that does
    not exist (every ``<subpackage>/<module>.py`` in backticks is looked up in the library)."""
    text = (ROOT / "README.md").read_text()
    lib = ROOT / "lib" / "vehicle_observers"
    cited = set(re.findall(r"`((?:[a-z_]+/)+[a-z_0-9]+\.py)`", text))
    subs = {p.name for p in lib.iterdir() if p.is_dir()}
    checked = [c for c in cited if c.split("/")[0] in subs]
    assert checked, "the README cites no library file: the pattern no longer matches"
    missing = [c for c in checked if not (lib / c).exists()]
    assert not missing, f"README cites missing files: {missing}"
