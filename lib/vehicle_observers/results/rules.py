"""Verdicts computed from declared rules.

A claim of a paper is judged by a :class:`Rule`: an expression over the run's metrics gives the
``value``; conditions on it (and on other metrics) give the verdict::

    Rule("bound34_max_ratio", reproduced="value <= 1", paper="||e|| below bound (34) at every sample",
         informative="value >= 0.1", digits=3,
         source="paper: (34) bounds ||e(t)|| at every t; chosen here: informative above 0.1")

* ``reproduced`` holds -> **reproduced**; else ``partly`` holds -> **partly**; else **differs**.
* ``Rule.no_number(value, paper)`` -> **not comparable** (the paper prints no number or
  behaviour to compare with; the value is still reported).
* ``Rule.not_comparable(value, paper, because)`` -> **not comparable** although the paper has a
  number: ``because`` says why this reproduction cannot test it.
* ``informative`` (optional) fails -> the verdict is qualified "holds but proves little"
  (e.g. a bound three orders of magnitude above the error).
* ``source``: where the thresholds come from, ``"paper: <quote or equation>"`` or
  ``"chosen here: <reason>"`` (or both, joined by ``"; "``), shown in REPRODUCTION.md.

Each claim also has a **kind** (:data:`KINDS`): a claim printed in a paper, or one of the
checks made beside the papers (benchmark targets, diagnostics, baselines, data checks), which
REPRODUCTION.md tables and counts apart.

When the compared value is close to a threshold (a ratio of 1.002 against ``value <= 1``),
:func:`distinguishing_digits` gives enough digits to show on which side it lies.

Expressions are Python syntax restricted to metric names, numbers, arithmetic, comparisons,
``and``/``or``/``not``, indexing and ``abs``/``min``/``max``/``len``/``all``/``any``; a metric whose
name is not an identifier (``revs.ekf.rmse_vy``) is read with ``metric('revs.ekf.rmse_vy')``. They
are written verbatim beside the verdict in REPRODUCTION.md, so a reader sees the rule.
"""

from __future__ import annotations

import ast
import math
from dataclasses import dataclass

import numpy as np

VERDICTS = ("reproduced", "partly", "differs", "not comparable")
#: kinds of claim -> plural title in REPRODUCTION.md. ``paper``: a claim printed in a paper (the
#: reproduction proper); the others are checks made here, counted apart: ``target`` a benchmark
#: target chosen here, ``diagnostic`` a check of a model or method (smoother against filter,
#: innovation whiteness, a model-validity test), ``baseline`` a baseline estimator's number,
#: ``data`` a check of a data set against its provenance.
KINDS = {"paper": "paper claims", "target": "benchmark targets", "diagnostic": "diagnostics",
         "baseline": "baselines", "data": "data checks"}
#: how a rule's ``source`` starts: the threshold is the paper's, or chosen in this repository
SOURCE_PREFIXES = ("paper:", "chosen here:")
_FUNCS = {"abs": abs, "min": min, "max": max, "len": len, "all": all, "any": any, "metric": None}
_NODES = (ast.Expression, ast.BoolOp, ast.BinOp, ast.UnaryOp, ast.Compare, ast.Name, ast.Load,
          ast.Constant, ast.Subscript, ast.Call, ast.Tuple, ast.List, ast.Slice, ast.And, ast.Or,
          ast.Not, ast.USub, ast.UAdd, ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow, ast.Mod,
          ast.FloorDiv, ast.Lt, ast.LtE, ast.Gt, ast.GtE, ast.Eq, ast.NotEq)


class RuleError(ValueError):
    """A rule that cannot be evaluated (unknown metric, disallowed syntax, non-finite value)."""


def _check_syntax(expr: str) -> ast.Expression:
    try:
        tree = ast.parse(expr, mode="eval")
    except SyntaxError as exc:
        raise RuleError(f"rule expression {expr!r}: {exc.msg}") from None
    for node in ast.walk(tree):
        if not isinstance(node, _NODES):
            raise RuleError(f"rule expression {expr!r}: {type(node).__name__} is not allowed")
        if isinstance(node, ast.Call) and not (isinstance(node.func, ast.Name)
                                               and node.func.id in _FUNCS):
            raise RuleError(f"rule expression {expr!r}: only {sorted(_FUNCS)} may be called")
    return tree


def evaluate(expr: str, names: dict):
    """Value of a rule expression with ``names`` (metric name -> value)."""
    tree = _check_syntax(expr)
    missing = sorted(({n.id for n in ast.walk(tree) if isinstance(n, ast.Name)} - set(_FUNCS)
                      | {n.args[0].value for n in ast.walk(tree) if isinstance(n, ast.Call)
                         and n.func.id == "metric" and n.args and isinstance(n.args[0], ast.Constant)})
                     - set(names))
    if missing:
        raise RuleError(f"rule expression {expr!r}: no metric named {', '.join(missing)} "
                        "(record it with Report.metric before the claim)")
    env = {k: (np.asarray(v) if isinstance(v, list) else v) for k, v in names.items()}
    funcs = {**_FUNCS, "metric": lambda k: env[k]}
    try:
        with np.errstate(all="ignore"):
            out = eval(compile(tree, "<rule>", "eval"), {"__builtins__": {}, **funcs}, env)
    except (ArithmeticError, IndexError, TypeError) as exc:
        raise RuleError(f"rule expression {expr!r}: {type(exc).__name__}: {exc} "
                        "(value not finite or not computable)") from None
    if isinstance(out, np.ndarray):
        out = out.tolist()
    if isinstance(out, np.generic):
        out = out.item()
    return out


@dataclass(frozen=True)
class Rule:
    """How the verdict of one claim is computed; see the module docstring.

    value : expression over metric names giving the compared quantity.
    reproduced, partly : conditions (expressions using ``value`` and metric names).
    paper : the paper's number or behaviour, as text (shown as the target).
    informative : condition; when it fails the verdict is marked "holds but proves little".
    digits : significant digits of the value in REPRODUCTION.md (more when the value is close
        to a threshold, :func:`distinguishing_digits`).
    source : where the thresholds come from: ``"paper: <quote or equation>"`` or
        ``"chosen here: <reason>"`` (both parts, joined by ``"; "``, when the paper gives the
        behaviour and the number is chosen here). Every rule of the notebooks and the
        reproductions has one (a repository test checks it); a ``no_number`` rule has no
        threshold and needs none.
    """

    value: str
    reproduced: str | None = None
    paper: str = ""
    partly: str | None = None
    informative: str | None = None
    digits: int = 3
    source: str = ""
    #: why the paper's claim cannot be compared here although it has a number (e.g. the
    #: reconstruction fixes the compared quantity); set by :meth:`not_comparable`
    because: str | None = None

    def __post_init__(self):
        for e in (self.value, self.reproduced, self.partly, self.informative):
            if e is not None:
                _check_syntax(e)
        if not isinstance(self.source, str) or (
                self.source and not self.source.startswith(SOURCE_PREFIXES)):
            raise RuleError(f"rule {self.value!r}: source must start with "
                            f"{' or '.join(repr(p) for p in SOURCE_PREFIXES)}, got {self.source!r}")

    @classmethod
    def no_number(cls, value: str, paper: str, digits: int = 3, source: str = "") -> Rule:
        """The paper gives no number or behaviour to test: verdict "not comparable"."""
        return cls(value=value, reproduced=None, paper=paper, digits=digits, source=source)

    @classmethod
    def not_comparable(cls, value: str, paper: str, because: str, digits: int = 3) -> Rule:
        """The paper gives a number, but this reproduction cannot test it (``because``: e.g. the
        reconstruction of an unprinted quantity fixes the compared value by construction):
        verdict "not comparable", the value still reported."""
        if not because:
            raise RuleError(f"rule {value!r}: not_comparable needs the reason (because=...)")
        return cls(value=value, reproduced=None, paper=paper, digits=digits, because=because)

    def thresholds(self, metrics: dict) -> list[float]:
        """The numbers ``value`` is compared with in the conditions: in every comparison with
        ``value`` on one side, the other side evaluated over ``metrics`` (a constant, or an
        expression of other metrics). Comparisons that cannot be evaluated are skipped."""
        v = evaluate(self.value, metrics)
        out = []
        for cond in (self.reproduced, self.partly, self.informative):
            if cond is None:
                continue
            for node in ast.walk(_check_syntax(cond)):
                if not isinstance(node, ast.Compare):
                    continue
                sides = [node.left, *node.comparators]
                for a, b in zip(sides, sides[1:]):
                    for this, other in ((a, b), (b, a)):
                        if isinstance(this, ast.Name) and this.id == "value":
                            try:
                                t = evaluate(ast.unparse(other), {**metrics, "value": v})
                            except RuleError:
                                continue
                            if isinstance(t, (int, float)) and not isinstance(t, bool):
                                out.append(float(t))
        return out

    def text(self) -> str:
        """The rule as written in REPRODUCTION.md."""
        if self.reproduced is None:
            if self.because:
                return f"`{self.value}`; not comparable: {self.because}"
            return f"`{self.value}`; no paper number to test"
        parts = [f"`{self.value}`; reproduced if `{self.reproduced}`"]
        if self.partly:
            parts.append(f"partly if `{self.partly}`")
        if self.informative:
            parts.append(f"informative if `{self.informative}`")
        return ", ".join(parts)

    def judge(self, metrics: dict) -> Judgement:
        """Verdict from ``metrics`` (name -> value)."""
        v = evaluate(self.value, metrics)
        _finite(v, self.value)
        names = {**metrics, "value": v}
        if self.reproduced is None:
            verdict = "not comparable"
        elif _true(evaluate(self.reproduced, names), self.reproduced):
            verdict = "reproduced"
        elif self.partly and _true(evaluate(self.partly, names), self.partly):
            verdict = "partly"
        else:
            verdict = "differs"
        weak = (verdict != "not comparable" and self.informative is not None
                and not _true(evaluate(self.informative, names), self.informative))
        return Judgement(verdict, v, weak)


@dataclass(frozen=True)
class Judgement:
    verdict: str
    value: object
    proves_little: bool = False


def _finite(v, expr):
    arr = np.asarray(v, dtype=float) if not isinstance(v, bool) else np.asarray(float(v))
    if not np.all(np.isfinite(arr)):
        raise RuleError(f"rule value {expr!r} is not finite: {v!r}")


def _true(x, expr) -> bool:
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    raise RuleError(f"rule condition {expr!r} must give True/False, got {x!r}")


def distinguishing_digits(value, thresholds, digits: int = 3, max_digits: int = 12) -> int:
    """Significant digits (at least ``digits``, at most ``max_digits``) with which ``value``,
    rounded, lies on the same side of every threshold as ``value`` itself, and differs from a
    threshold it differs from: 1.002 against 1 needs 4 digits ("1.002", not "1"). Values
    that are not finite floats keep ``digits``."""
    if isinstance(value, bool) or not isinstance(value, float) or not math.isfinite(value):
        return digits
    ts = [float(t) for t in thresholds if math.isfinite(float(t))]
    d = digits
    while d < max_digits:
        r = float(f"{value:.{d}g}")
        if all(np.sign(r - t) == np.sign(value - t) for t in ts):
            break
        d += 1
    return d


def round_sig(x, digits: int):
    """``x`` (float, or nested list / dict of them) rounded to ``digits`` significant digits; integers and
    booleans are kept exact."""
    if isinstance(x, (list, tuple)):
        return [round_sig(v, digits) for v in x]
    if isinstance(x, dict):
        return {k: round_sig(v, digits) for k, v in x.items()}
    if isinstance(x, (bool, int)) or not isinstance(x, float):
        return x  # counts and flags are exact
    x = float(x)
    if x == 0 or not math.isfinite(x):
        return x
    return float(f"{x:.{digits}g}")


def fmt(x, digits: int = 3) -> str:
    """Short text of a number or vector: 3-4 significant digits, long vectors summarised."""
    if isinstance(x, dict):
        text = "{" + ", ".join(f"{k}: {fmt(v, digits)}" for k, v in x.items()) + "}"
        return text if len(text) <= 160 else f"table of {len(x)} entries (metrics.json)"
    if isinstance(x, (list, tuple)):
        if not _numeric(x):
            text = "[" + ", ".join(fmt(v, digits) for v in x) + "]"
            return text if len(text) <= 160 else f"{len(x)} entries (metrics.json)"
        flat = np.asarray(x, dtype=float).ravel() if _numeric(x) else None
        if flat is not None and flat.size > 6 and np.all(np.isfinite(flat)):
            return (f"{flat.size} values in [{fmt(float(flat.min()), digits)}, "
                    f"{fmt(float(flat.max()), digits)}]")
        return "[" + ", ".join(fmt(v, digits) for v in x) + "]"
    if isinstance(x, bool):
        return str(x)
    if isinstance(x, (int, float, np.floating, np.integer)):
        x = float(x)
        if not math.isfinite(x):
            return str(x)
        if x == int(x) and abs(x) < 1e6:
            return str(int(x))
        return f"{x:.{digits}g}"
    return str(x)


def _numeric(x) -> bool:
    try:
        np.asarray(x, dtype=float)
        return True
    except (TypeError, ValueError):
        return False
