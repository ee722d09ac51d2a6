"""A car the interval LMIs refuse is refused again from the process cache, with the same
message and attributes, without re-solving (interval-coordinates then fusion-interval on one
log solved the eight kappa candidates twice)."""

from __future__ import annotations

import pytest
from vehicle_observers.core.errors import InfeasibleDesign
from vehicle_observers.estimation import adapters as A
from vehicle_observers.models.vehicle import load_vehicle


@pytest.mark.parametrize("fn", [A.interval_design, A.coordinate_interval_design])
def test_refusal_is_cached_in_the_process(monkeypatch, fn):
    veh = load_vehicle("yacine2015")
    calls = []

    def refuse(kind, key_args, build, cache):
        calls.append(kind)
        raise InfeasibleDesign(f"{kind}: planted refusal", lmi="Xi[1]", violation=0.5,
                               status="infeasible")

    monkeypatch.setattr(A, "_disk_design", refuse)
    monkeypatch.setattr(A, "_IV_CACHE", {})
    errs = []
    for _ in range(3):
        with pytest.raises(InfeasibleDesign) as ei:
            fn(veh, 0.01)
        errs.append(ei.value)
    assert len(calls) == 1                          # solved once, refused three times
    assert len({id(e) for e in errs}) == 3          # a fresh exception each time
    for e in errs:
        assert "planted refusal" in str(e)
        assert (e.lmi, e.violation, e.status) == ("Xi[1]", 0.5, "infeasible")
    # a design that succeeds is cached as before
    monkeypatch.setattr(A, "_disk_design", lambda kind, key_args, build, cache:
                        (calls.append(kind) or "design", 0.1))
    assert fn(veh, 0.02) == ("design", 0.1) == fn(veh, 0.02)
    assert len(calls) == 2
