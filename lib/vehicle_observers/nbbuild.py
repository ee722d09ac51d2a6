"""Write a notebook (without outputs) from a list of cells; used to author the notebooks.

    from vehicle_observers.nbbuild import write_notebook
    write_notebook("notebooks/02_premise_estimation.ipynb", [
        ("md", "# Title ..."),
        ("params", "seed = 0\\nquick = False\\nfigures_dir = '../figures'"),
        ("code", "from vehicle_observers import ..."),
    ])

The ``params`` cell gets the papermill ``parameters`` tag. The kernel is the project's
(``vehicle-observers``, registered by ``make``).
"""

from __future__ import annotations

import nbformat
from nbformat.v4 import new_code_cell, new_markdown_cell, new_notebook


def write_notebook(path, cells):
    nb = new_notebook()
    nb.metadata["kernelspec"] = {"name": "vehicle-observers", "display_name":
                                 "Python (vehicle-observers)", "language": "python"}
    nb.metadata["language_info"] = {"name": "python"}
    for kind, src in cells:
        src = src.strip("\n")
        if kind == "md":
            nb.cells.append(new_markdown_cell(src))
        elif kind == "code":
            nb.cells.append(new_code_cell(src))
        elif kind == "params":
            c = new_code_cell(src)
            c.metadata["tags"] = ["parameters"]
            nb.cells.append(c)
        else:
            raise ValueError(f"cell kind {kind!r}: use 'md', 'code' or 'params'")
    for i, c in enumerate(nb.cells):  # stable ids -> deterministic files
        c["id"] = f"cell-{i:02d}"
    nbformat.validate(nb)
    nbformat.write(nb, str(path))
    return path
