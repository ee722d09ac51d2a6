"""Array helpers shared by the observers and the figures."""

import numpy as np


def decimate(t, *ys, max_points: int = 4000):
    """Thin time series for plotting (keeps every k-th sample), so figures stay small."""
    t = np.asarray(t)
    k = max(1, int(np.ceil(len(t) / max_points)))
    return (t[::k],) + tuple(np.asarray(y)[::k] for y in ys)
