"""Deterministic excitation signals for model checks (no randomness unless a seed is given)."""

from __future__ import annotations

import numpy as np


def time_grid(duration: float, dt: float) -> np.ndarray:
    n = int(round(duration / dt)) + 1
    return np.arange(n) * dt


def chirp(t, f0: float, f1: float, amplitude: float):
    """Linear chirp ``A sin(2 pi (f0 t + (f1 - f0) t^2 / (2 T)))`` over the grid ``t``."""
    t = np.asarray(t, dtype=float)
    T = max(t[-1] - t[0], 1e-12)
    tau = t - t[0]
    return amplitude * np.sin(2 * np.pi * (f0 * tau + (f1 - f0) * tau**2 / (2 * T)))


def speed_ramp(t, v0: float, v1: float, smooth: float = 0.2):
    """Smooth (raised-cosine) speed change from ``v0`` to ``v1`` [m/s] over the grid."""
    t = np.asarray(t, dtype=float)
    s = (t - t[0]) / max(t[-1] - t[0], 1e-12)
    w = np.clip((s - smooth) / (1 - 2 * smooth), 0, 1)
    return v0 + (v1 - v0) * (1 - np.cos(np.pi * w)) / 2
