"""Regeneration check: do the committed results survive a fresh regeneration?

    python -m vehicle_observers.results.check              # regenerate into build/check, compare
    python -m vehicle_observers.results.check --compare A  # compare figures/ with a folder A only
    python -m vehicle_observers.results.check --only 03,05 # regenerate and compare two notebooks

(``make check``.) Every notebook is run in full mode into ``build/check/figures``; then every
committed metric in ``figures/<notebook>/metrics.json`` is compared with the regenerated one
and every claim's verdict and kind (paper claim, benchmark target, diagnostic, baseline, data
check) must be identical; and what every saved figure shows (``figure_data.json`` of each
figures folder, :func:`compare_figure_data`) must be the same: colours, line styles, hatches,
labels, counts and scales exactly, plotted data within :data:`FIGURE_RTOL` of its axis span. A
numeric metric may move by its tolerance:

* one unit in the last stored digit (metrics are stored at ``digits`` significant digits, so a
  value sitting on a rounding boundary may flip by one unit), or
* the metric's own declared ``rtol`` / ``atol`` (set where the value depends on the LMI solver or
  the platform beyond its stored precision; ``metrics.json`` records the reason, ``why``).

A table of every drift is printed (metric, committed, regenerated, tolerance); the exit status
is 1 on a verdict or kind change, a missing/new metric or claim, or a drift beyond tolerance,
else 0.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
from dataclasses import dataclass
from pathlib import Path

from vehicle_observers.data.logs import repo_root
from vehicle_observers.results.rules import fmt


@dataclass
class Drift:
    notebook: str
    what: str
    committed: object
    regenerated: object
    tolerance: str
    ok: bool


def _last_digit_unit(x: float, digits: int) -> float:
    if x == 0 or not math.isfinite(x):
        return 0.0
    return 10.0 ** (math.floor(math.log10(abs(x))) - digits + 1)


def _num_close(a, b, entry) -> tuple[bool, float]:
    """``(within tolerance, |a - b|)`` for two numbers of one metric ``entry``."""
    if isinstance(a, str) or isinstance(b, str):  # "nan" / "inf" stored as text
        return a == b, 0.0
    digits = int(entry.get("digits", 4))
    tol = max(_last_digit_unit(float(a), digits), _last_digit_unit(float(b), digits),
              float(entry.get("atol", 0.0)), float(entry.get("rtol", 0.0)) * abs(float(a)))
    d = abs(float(a) - float(b))
    return d <= tol * (1 + 1e-9), d


def _compare_values(a, b, entry) -> tuple[bool, float]:
    if isinstance(a, bool) or isinstance(b, bool) or a is None or b is None:
        return a == b, 0.0
    if isinstance(a, (int, float, str)) and isinstance(b, (int, float, str)):
        return _num_close(a, b, entry)
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return False, math.inf
        res = [_compare_values(x, y, entry) for x, y in zip(a, b)]
        return all(r[0] for r in res), max((r[1] for r in res), default=0.0)
    if isinstance(a, dict) and isinstance(b, dict):
        if set(a) != set(b):
            return False, math.inf
        res = [_compare_values(a[k], b[k], entry) for k in a]
        return all(r[0] for r in res), max((r[1] for r in res), default=0.0)
    return a == b, 0.0


def _tol_text(entry) -> str:
    parts = [f"{entry.get('digits', 4)} digits"]
    if "rtol" in entry:
        parts.append(f"rtol {entry['rtol']:g}")
    if "atol" in entry:
        parts.append(f"atol {entry['atol']:g}")
    return ", ".join(parts)


def _kind(claim: dict) -> str:
    """A claim's kind (documents written before kinds existed hold paper claims only)."""
    return claim.get("kind", "paper")


def compare_doc(old: dict, new: dict) -> list[Drift]:
    """Drifts between two metrics.json documents of one notebook (committed, regenerated)."""
    nb = old.get("notebook", "?")
    out = []
    om, nm = old["metrics"], new["metrics"]
    for k in sorted(set(om) | set(nm)):
        if k not in nm or k not in om:
            out.append(Drift(nb, f"metric {k}", om.get(k, {}).get("value", "(absent)"),
                             nm.get(k, {}).get("value", "(absent)"), "present in both", False))
            continue
        a, b = om[k]["value"], nm[k]["value"]
        if a == b:
            continue
        ok, _ = _compare_values(a, b, om[k])
        out.append(Drift(nb, f"metric {k}", a, b, _tol_text(om[k]), ok))
    oc, nc = old.get("claims", []), new.get("claims", [])
    key = lambda c: (c["paper"], c["item"])  # noqa: E731
    ocd, ncd = {key(c): c for c in oc}, {key(c): c for c in nc}
    for k in sorted(set(ocd) | set(ncd)):
        if k not in ncd or k not in ocd:
            out.append(Drift(nb, f"claim {k[0]}: {k[1]}", ocd.get(k, {}).get("verdict", "(absent)"),
                             ncd.get(k, {}).get("verdict", "(absent)"), "present in both", False))
        elif ocd[k]["verdict"] != ncd[k]["verdict"]:
            out.append(Drift(nb, f"claim {k[0]}: {k[1]}", ocd[k]["verdict"], ncd[k]["verdict"],
                             "identical verdict", False))
        if k in ocd and k in ncd and _kind(ocd[k]) != _kind(ncd[k]):
            out.append(Drift(nb, f"claim kind {k[0]}: {k[1]}", _kind(ocd[k]), _kind(ncd[k]),
                             "identical kind", False))
    return out


def compare_dirs(committed: Path, regenerated: Path, only=()) -> list[Drift]:
    """Drifts of every ``<notebook>/metrics.json`` of ``committed`` against ``regenerated``
    (only the notebooks whose name starts with one of ``only``, when given)."""
    out = []
    for mj in sorted(committed.glob("*/metrics.json")):
        if only and not mj.parent.name.startswith(tuple(only)):
            continue
        if not (mj.parent / "metrics.json").exists():
            continue
        other = regenerated / mj.parent.name / "metrics.json"
        old = json.loads(mj.read_text())
        if "notebook" not in old:  # not a notebook's folder (e.g. the benchmark's)
            continue
        if not other.exists():
            out.append(Drift(old["notebook"], "metrics.json", "present", "(absent)",
                             "regenerated", False))
            continue
        out.extend(compare_doc(old, json.loads(other.read_text())))
    return out


#: the file of every figures folder with what each figure shows
#: (:func:`vehicle_observers.results.plotting.figure_data`)
FIGURE_DATA = "figure_data.json"
#: a plotted summary number (min, max, mean of a series, an axis limit) may move by this
#: fraction of its axis' span (or of its own size where there is no axis): half a percent
#: is below what a reader sees on a figure, far above the solver's round-off
FIGURE_RTOL = 5e-3
#: a number printed inside a title, label or text may move by this fraction (numbers shown
#: with 3 significant digits; a value on a rounding edge flips the last one)
TEXT_RTOL = 2e-2
_NUM = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def _text_close(a: str, b: str) -> bool:
    """Two texts equal but for numbers within :data:`TEXT_RTOL` (or one unit of their last
    printed digit)."""
    if a == b:
        return True
    if _NUM.sub("#", a) != _NUM.sub("#", b):
        return False
    for x, y in zip(_NUM.findall(a), _NUM.findall(b)):
        fx, fy = float(x), float(y)
        digits = len(x.split(".")[1].split("e")[0].split("E")[0]) if "." in x else 0
        unit = 10.0 ** -digits if "e" not in x.lower() else 0.0
        if abs(fx - fy) > max(TEXT_RTOL * max(abs(fx), abs(fy)), unit * 1.0001):
            return False
    return True


def _summary_close(a: dict, b: dict, span: float) -> bool:
    if a.get("n") != b.get("n"):
        return False
    scale = span if span > 0 else max([abs(a.get(k, 0.0)) for k in ("min", "max")] + [1e-300])
    for k in ("min", "max", "mean"):
        if k in a and abs(a[k] - b[k]) > FIGURE_RTOL * scale + 1e-12 * max(abs(a[k]), 1.0):
            return False
    return True


def _walk(a, b, path: str, spans: dict, out: list[tuple[str, object, object]]):
    """Append ``(path, committed, regenerated)`` for every difference of two figure-data
    trees beyond the tolerances."""
    if isinstance(a, dict) and isinstance(b, dict):
        if set(a) >= {"n"} and set(a) <= {"n", "min", "max", "mean"}:
            axis = path.rsplit(".", 1)[-1]
            if not _summary_close(a, b, spans.get(axis, 0.0)):
                out.append((path, a, b))
            return
        if "xlim" in a and "ylim" in a:   # an axes: its spans set the tolerance of its data
            spans = {"x": abs(a["xlim"][1] - a["xlim"][0]), "y": abs(a["ylim"][1] - a["ylim"][0])}
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                out.append((f"{path}.{k}", a.get(k, "(absent)"), b.get(k, "(absent)")))
            else:
                _walk(a[k], b[k], f"{path}.{k}", spans, out)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out.append((f"{path} (count)", len(a), len(b)))
            return
        if path.endswith(("xlim", "ylim")) and all(isinstance(x, (int, float)) for x in a + b):
            span = max(abs(a[1] - a[0]), abs(b[1] - b[0])) if len(a) == 2 else 0.0
            if any(abs(x - y) > FIGURE_RTOL * span + 1e-12 for x, y in zip(a, b)):
                out.append((path, a, b))
            return
        for i, (x, y) in enumerate(zip(a, b)):
            _walk(x, y, f"{path}[{i}]", spans, out)
    elif isinstance(a, str) and isinstance(b, str):
        if not _text_close(a, b):
            out.append((path, a, b))
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        if abs(a - b) > FIGURE_RTOL * max(abs(a), abs(b)) + 1e-12:
            out.append((path, a, b))
    elif a != b:
        out.append((path, a, b))


def compare_figure_data(notebook: str, old: dict, new: dict) -> list[Drift]:
    """Drifts between two ``figure_data.json`` documents ``{figure: data}`` of one folder: a
    figure missing or new, a colour, style, hatch, label, count or scale changed, or plotted
    data moved by more than :data:`FIGURE_RTOL` of its axis span (see
    :func:`vehicle_observers.results.plotting.figure_data`). Every drift is beyond tolerance."""
    out = []
    for name in sorted(set(old) | set(new)):
        if name not in old or name not in new:
            out.append(Drift(notebook, f"figure {name}", "present" if name in old else "(absent)",
                             "present" if name in new else "(absent)", "present in both", False))
            continue
        diffs: list[tuple[str, object, object]] = []
        _walk(old[name], new[name], "", {}, diffs)
        for path, a, b in diffs:
            out.append(Drift(notebook, f"figure {name}{path}", _short(a), _short(b),
                             "what the figure shows (colours, styles, labels exact; data "
                             f"{FIGURE_RTOL:g} of the axis span)", False))
    return out


def _short(x) -> str:
    s = json.dumps(x) if not isinstance(x, str) else x
    return s if len(s) <= 80 else s[:77] + "..."


def compare_figure_dirs(committed: Path, regenerated: Path, only=()) -> list[Drift]:
    """:func:`compare_figure_data` of every ``figure_data.json`` below ``committed`` (a report's
    ``<notebook>/`` and a lesson's ``<notebook>/lesson/``) against the same file below
    ``regenerated``."""
    out = []
    for fd in sorted(committed.glob(f"*/{FIGURE_DATA}")) + sorted(committed.glob(f"*/lesson/{FIGURE_DATA}")):
        rel = fd.relative_to(committed)
        nb = rel.parts[0]
        if only and not nb.startswith(tuple(only)):
            continue
        other = regenerated / rel
        label = str(rel.parent)
        if not other.exists():
            out.append(Drift(label, FIGURE_DATA, "present", "(absent)", "regenerated", False))
            continue
        out.extend(compare_figure_data(label, json.loads(fd.read_text()),
                                       json.loads(other.read_text())))
    return out


def drift_table(drifts: list[Drift]) -> str:
    """Markdown table of the drifts (or a line saying there are none)."""
    if not drifts:
        return ("no drift: every metric identical at its stored precision, every verdict and kind "
                "identical, every figure showing the same")
    rows = ["| notebook | what | committed | regenerated | tolerance | within |",
            "|---|---|---|---|---|---|"]
    for d in drifts:
        rows.append(f"| {d.notebook} | {d.what} | {fmt(d.committed, 4)} | {fmt(d.regenerated, 4)} "
                    f"| {d.tolerance} | {'yes' if d.ok else '**NO**'} |")
    return "\n".join(rows)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[1])
    ap.add_argument("--compare", default=None,
                    help="compare figures/ with this folder of regenerated results; no run")
    ap.add_argument("--committed", default=None, help="committed folder (default: figures/)")
    ap.add_argument("--build", default="build/check")
    ap.add_argument("--timeout", type=int, default=1200)
    ap.add_argument("--only", default="", help="comma-separated notebook prefixes, e.g. 01,03")
    args = ap.parse_args(argv)
    only = tuple(x for x in args.only.split(",") if x)
    root = repo_root()
    committed = Path(args.committed) if args.committed else root / "figures"
    if args.compare:
        regenerated = Path(args.compare)
    else:
        from vehicle_observers.results import pipeline

        build = root / args.build
        regenerated = build / "figures"
        rc = pipeline.main(["--figures", str(regenerated), "--build", str(build / "notebooks"),
                            "--timeout", str(args.timeout)]
                           + (["--only", args.only] if only else []))
        if rc != 0:
            return rc
    drifts = compare_dirs(committed, regenerated, only) + compare_figure_dirs(committed, regenerated, only)
    print(drift_table(drifts))
    bad = [d for d in drifts if not d.ok]
    print(f"\n{len(drifts)} drift(s), {len(bad)} beyond tolerance or changed verdicts or kinds")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
