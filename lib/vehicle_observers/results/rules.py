"""Verdicts computed from declared rules.

A claim of a paper is judged by a :class:`Rule`: an expression over the run's metrics gives the
``value``; conditions on it (and on other metrics) give the verdict::

    Rule("bound34_max_ratio", reproduced="value <= 1", paper="||e|| below bound (34) at every sample",
         informative="value >= 0.1", digits=3)

* ``reproduced`` holds -> **reproduced**; else ``partly`` holds -> **partly**; else **differs**.
* ``Rule.no_number(value, paper)`` -> **not comparable** (the paper prints no number or
  behaviour to compare with; the value is still reported).
* ``informative`` (optional) fails -> the verdict is qualified "holds but proves little"
  (e.g. a bound three orders of magnitude above the error).

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
    digits : significant digits of the value in REPRODUCTION.md.
    """

    value: str
    reproduced: str | None = None
    paper: str = ""
    partly: str | None = None
    informative: str | None = None
    digits: int = 3

    def __post_init__(self):
        for e in (self.value, self.reproduced, self.partly, self.informative):
            if e is not None:
                _check_syntax(e)

    @classmethod
    def no_number(cls, value: str, paper: str, digits: int = 3) -> Rule:
        """The paper gives no number or behaviour to test: verdict "not comparable"."""
        return cls(value=value, reproduced=None, paper=paper, digits=digits)

    def text(self) -> str:
        """The rule as written in REPRODUCTION.md."""
        if self.reproduced is None:
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
