"""The serial run of the tiny campaign (campaignkit.TINY): the reference every other engine
must equal bit for bit."""

from __future__ import annotations

import pytest
from campaignkit import TINY


@pytest.fixture(scope="session")
def tiny_serial(tmp_path_factory):
    """The serial run of :data:`TINY`: ``(spec, folder, results table, lmi table)``."""
    from vehicle_observers.campaign import load_spec, read_lmi, read_results, run

    out = tmp_path_factory.mktemp("tiny_serial") / "run"
    spec = load_spec(TINY)
    run(spec, out, engine="serial", progress=False)
    return spec, out, read_results(out), read_lmi(out)

