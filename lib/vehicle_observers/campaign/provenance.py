"""What code made a result: package version, the source hash of every estimator's module and
plug-in, and the options chosen.

:func:`code_provenance` is written beside every estimate of the command line
(``EST.csv.provenance.json``) and into every campaign folder (``provenance.json``); a
campaign resumed with different code is refused with one line naming what changed
(:func:`changes`), or, with ``recompute``, the batches of the estimators it affects are run
again (:func:`affected_estimators`). The hash covers the module that registered each
estimator (for a plug-in: its file; for a built-in one: its ``estimation`` module) and each
plug-in file loaded; ``library_sha256`` covers every module of the installed packages
(:func:`vehicle_observers.core.source.package_sha256`), so a change deeper in the library (a
filter kernel, a tyre model) marks every estimator's results as made by other code.
"""

from __future__ import annotations

import json
import platform
from pathlib import Path

#: file of a campaign folder holding the provenance of its results
FILE = "provenance.json"


def code_provenance(estimators: dict, options: dict | None = None, plugins=()) -> dict:
    """Provenance of results made by ``estimators`` (name -> :class:`EstimatorSpec`) with
    ``options`` (name -> options dict) after loading ``plugins`` (module names or ``.py``
    paths). JSON-able; equal on every machine for the same code and options (no paths or
    times)."""
    import numpy as np

    import vehicle_observers
    from vehicle_observers.core.source import package_sha256
    from vehicle_observers.estimation import registry

    est = {}
    for name, spec in estimators.items():
        est[name] = {"origin": spec.origin, "plugin": spec.plugin,
                     "source_sha256": registry.source_sha256(spec.origin)}
    plug = {}
    for ref in plugins:
        mod = Path(str(ref)).stem if str(ref).endswith(".py") else str(ref)
        plug[Path(str(ref)).name if str(ref).endswith(".py") else str(ref)] = \
            registry.source_sha256(mod)
    opts = {k: dict(v) for k, v in (options or {}).items() if v}
    return {"package": "vehicle_observers", "version": vehicle_observers.__version__,
            "library_sha256": package_sha256(),
            "python": platform.python_version(), "numpy": np.__version__,
            "estimators": est, "plugins": plug,
            "options": json.loads(json.dumps(opts, sort_keys=True, default=repr))}


def changes(old: dict, new: dict) -> list[str]:
    """What differs between two provenances, one short phrase each (empty: the same code)."""
    out = []
    if old.get("version") != new.get("version"):
        out.append(f"package version {old.get('version')} -> {new.get('version')}")
    if old.get("library_sha256") != new.get("library_sha256"):
        out.append(f"library source {str(old.get('library_sha256'))[:12]} -> "
                   f"{str(new.get('library_sha256'))[:12]}")
    oe, ne = old.get("estimators", {}), new.get("estimators", {})
    for n in sorted(set(oe) | set(ne)):
        a, b = oe.get(n), ne.get(n)
        if a is None or b is None:
            continue                      # a different plan is the spec's business
        if a.get("source_sha256") != b.get("source_sha256"):
            out.append(f"estimator {n!r}: source of {b.get('origin')} changed")
    op, np_ = old.get("plugins", {}), new.get("plugins", {})
    for n in sorted(set(op) | set(np_)):
        if op.get(n) != np_.get(n):
            out.append(f"plug-in {n}: " + ("source changed" if n in op and n in np_ else
                                           "added" if n in np_ else "removed"))
    if old.get("options", {}) != new.get("options", {}):
        out.append("options changed")
    return out


def affected_estimators(old: dict, new: dict) -> set[str] | None:
    """Estimators whose results ``changes`` invalidates; ``None``: all of them (the package
    version, the library source, a plug-in file or the options changed)."""
    if (old.get("version") != new.get("version")
            or old.get("library_sha256") != new.get("library_sha256")
            or old.get("plugins") != new.get("plugins")
            or old.get("options", {}) != new.get("options", {})):
        return None
    oe, ne = old.get("estimators", {}), new.get("estimators", {})
    return {n for n in ne if n in oe and oe[n].get("source_sha256") != ne[n].get("source_sha256")}


def read(folder) -> dict | None:
    f = Path(folder) / FILE
    try:
        return json.loads(f.read_text())
    except FileNotFoundError:
        return None
    except (OSError, ValueError):
        return {}


def write(folder, prov: dict):
    import os

    f = Path(folder) / FILE
    tmp = f.with_name(f"{f.name}.partial-{os.getpid()}")
    tmp.write_text(json.dumps(prov, indent=1, sort_keys=True) + "\n")
    os.replace(tmp, f)
