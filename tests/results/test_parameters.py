"""Notebook parameters (papermill) are a real boolean and a real integer, or refused.

Catches the misreadings of ``papermill -r quick no`` / ``-r quick False`` (a non-empty
string is true: quick mode run and recorded as quick = true) and ``-p seed 1.5`` (run as
seed 1), through :func:`validate_parameters` and :class:`Report`, which every notebook
creates before its first computation."""

from __future__ import annotations

import numpy as np
import pytest
from vehicle_observers.results.parameters import ParameterError, validate_parameters
from vehicle_observers.results.reporting import Report


@pytest.mark.parametrize("quick", ["no", "False", "false", "0", "", "True", "yes", "off", None,
                                   0, 1, 0.0, [False]])
def test_quick_that_is_not_a_boolean_is_refused(quick, tmp_path):
    """Catches: a string or number taken by truthiness (``"no"`` running quick mode)."""
    with pytest.raises(ParameterError, match="parameter quick"):
        validate_parameters(quick=quick)
    with pytest.raises(ParameterError, match="parameter quick"):
        Report("00_start_here", tmp_path, quick=quick)
    assert not (tmp_path / "00_start_here").exists()     # refused before any folder


@pytest.mark.parametrize("seed", [1.5, 1.0, "3", True, -1, 2 ** 64, None, np.float64(2.0)])
def test_seed_that_is_not_an_integer_is_refused(seed, tmp_path):
    """Catches: ``-p seed 1.5`` cut to seed 1, a text or boolean seed."""
    with pytest.raises(ParameterError, match="parameter seed"):
        validate_parameters(seed=seed)
    with pytest.raises(ParameterError, match="parameter seed"):
        Report("00_start_here", tmp_path, seed=seed)


@pytest.mark.parametrize("quick, seed", [(True, 0), (False, 7), (np.bool_(True), np.int64(3)),
                                         (False, 2 ** 63 - 1)])
def test_real_booleans_and_integers_pass_unchanged(quick, seed, tmp_path):
    """Catches: a check that refuses the values papermill's -p gives."""
    assert validate_parameters(quick=quick, seed=seed) == (bool(quick), int(seed))
    rep = Report("00_start_here", tmp_path, quick=quick, seed=seed)
    assert rep.quick is bool(quick) and rep.seed == int(seed)
