"""Error metrics: known answers and the empty-selection error."""

import numpy as np
import pytest
from vehicle_observers.core import metrics as M


def test_known_answers():
    est, ref = np.array([1.0, -1.0, 3.0, 0.0]), np.zeros(4)
    assert M.rmse(est, ref) == pytest.approx(np.sqrt(11 / 4))
    assert M.max_abs(est, ref) == 3.0
    mask = np.array([True, True, False, False])
    assert M.rmse(est, ref, mask) == 1.0 and M.max_abs(est, ref, mask) == 1.0
    t = np.arange(5.0)
    assert M.settling_time(t, [1.0, 0.5, 0.01, 0.0, 0.0]) == 2.0
    assert np.isnan(M.settling_time(t, [1.0, 0.5, 0.01, 0.0, 0.5]))
    assert M.overshoot([1.0, -0.3, 0.1]) == pytest.approx(0.3)
    assert M.enclosure_rate([0, 0, 0], [0.5, 1.5, -0.1], [1, 1, 1]) == pytest.approx(1 / 3)


@pytest.mark.parametrize("fn", [M.rmse, M.max_abs])
def test_empty_selection_is_a_clear_error(fn):
    with pytest.raises(ValueError, match="selection is empty"):
        fn([1.0, 2.0], [0.0, 0.0], np.array([False, False]))
