"""Helpers of the notebook tests: what an executed lesson or solutions notebook printed."""

import re


def outputs(executed):
    """(printed text, statuses of the exercise checks in order) of an executed notebook."""
    import nbformat

    nb = nbformat.read(str(executed), as_version=4)
    text, status = [], []
    for c in nb.cells:
        for o in c.get("outputs", []):
            if o.get("output_type") == "stream":
                text.append(o["text"])
            html = o.get("data", {}).get("text/html", "")
            status += re.findall(r'data-status="([^"]+)"', html)
    return "\n".join(text), status


def differences(text):
    """The values printed by a lesson's comparisons with the compiled library
    (``... max |difference| = <value>``)."""
    return [float(x) for x in re.findall(r"max \|difference\|[^=]*= ([0-9.e+-]+)", text)]
