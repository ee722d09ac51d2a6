"""The README section "Designing an observer with LMIs" runs as written (its Python block is
extracted and executed): catches an example that no longer matches the layer's API, a design
that stops being certified, or an observer that no longer tracks the simulated plant."""

import re

from vehicle_observers.data.logs import repo_root


def readme_block() -> str:
    text = (repo_root() / "README.md").read_text()
    sec = text.split("## Designing an observer with LMIs", 1)[1].split("\n## ", 1)[0]
    m = re.search(r"```python\n(.*?)```", sec, re.S)
    assert m, "no python block in the README section"
    return m.group(1)


def test_readme_lmi_example_runs_as_written(capsys):
    """Executes the block; its own asserts check 'certified' and the tracking error."""
    ns: dict = {}
    exec(compile(readme_block(), "README.md:lmi-example", "exec"), ns)
    out = capsys.readouterr().out
    assert "certified" in out and "vertex H-infinity norms" in out
    assert ns["opt"].optimum < ns["opt"].value
    assert all(v <= ns["opt"].value for v in ns["opt"].design.certificate.hinf.values())
