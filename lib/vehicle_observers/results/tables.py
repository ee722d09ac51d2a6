"""Rounded tables for notebooks: HTML in a notebook, aligned text elsewhere."""

from __future__ import annotations

import html

from vehicle_observers.results.rules import fmt


class Table:
    """Rows (list of dicts) shown with ``digits`` significant digits; renders as HTML in
    Jupyter (``_repr_html_``) and as aligned text in a terminal (``__repr__``)."""

    def __init__(self, rows, columns=None, digits: int = 3, title: str = ""):
        rows = [dict(r) for r in rows]
        if columns is None:
            columns = []
            for r in rows:
                columns += [k for k in r if k not in columns]
        self.columns = list(columns)
        self.rows = rows
        self.digits = digits
        self.title = title

    def cells(self) -> list[list[str]]:
        return [[fmt(r.get(c, ""), self.digits) for c in self.columns] for r in self.rows]

    def _repr_html_(self) -> str:
        head = "".join(f"<th>{html.escape(str(c))}</th>" for c in self.columns)
        body = "".join("<tr>" + "".join(f"<td>{html.escape(x)}</td>" for x in row) + "</tr>"
                       for row in self.cells())
        cap = f"<caption>{html.escape(self.title)}</caption>" if self.title else ""
        return f"<table>{cap}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"

    def __repr__(self) -> str:
        cells = [list(map(str, self.columns))] + self.cells()
        w = [max(len(r[i]) for r in cells) for i in range(len(self.columns))]
        lines = ["  ".join(x.rjust(w[i]) for i, x in enumerate(r)) for r in cells]
        lines.insert(1, "  ".join("-" * n for n in w))
        return (self.title + "\n" if self.title else "") + "\n".join(lines)


def show_table(rows, columns=None, digits: int = 3, title: str = "") -> Table:
    """A :class:`Table` of ``rows``; as the last expression of a cell it renders as a table."""
    return Table(rows, columns, digits, title)


def metric_table(values: dict, names=None, digits: int = 3, title: str = "") -> Table:
    """Two-column table (metric, value) of ``values`` (e.g. ``rep.values()``) for ``names``."""
    names = list(values) if names is None else list(names)
    return Table([{"metric": n, "value": values[n]} for n in names], ["metric", "value"], digits,
                 title)
