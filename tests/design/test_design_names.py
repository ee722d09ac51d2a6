"""One class named ObserverDesign in the library (the synthesis layer's); Theorem 1's result
of Yacine 2015 is Theorem1Design, its former name still resolving to it with a warning."""

import re
from pathlib import Path

import pytest
import vehicle_observers
from vehicle_observers.design.synthesis import ObserverDesign
from vehicle_observers.observers import ts_premise


def test_one_observer_design_class():
    """Exactly one ``class ObserverDesign`` in lib/vehicle_observers and its reproductions
    (catches a second, unrelated class under the same name coming back)."""
    roots = [Path(vehicle_observers.__file__).parent,
             Path(vehicle_observers.__file__).parent.parent / "vehicle_observers_papers"]
    hits = [p for r in roots for p in r.rglob("*.py")
            if re.search(r"^class ObserverDesign\b", p.read_text(), re.M)]
    assert [p.name for p in hits] == ["synthesis.py"]
    assert ObserverDesign.__module__ == "vehicle_observers.design.synthesis"
    with pytest.warns(DeprecationWarning, match="Theorem1Design"):
        assert ts_premise.ObserverDesign is ts_premise.Theorem1Design
    with pytest.raises(AttributeError):
        ts_premise.NoSuchName  # noqa: B018
