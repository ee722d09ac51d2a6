"""The speed benchmarks ``make bench`` runs beside the accuracy benchmark.

:data:`SPEED_TOPICS` names, per topic, a module with ``run(quick) -> rows`` ``{"component",
"steps", "seconds", "us_per_step", ...}`` (or ``"module:function"`` for another function of
that form): the library's own (:mod:`vehicle_observers.bench`: every registered estimator on
one generated log with its ratio to filterpy's EKF, and the command line end to end), each
reproduction's ``speed`` module and the leaderboard's richest causal estimator
(:func:`vehicle_observers_papers.leanza_2021.leaderboard.speed_rows`).
"""

from __future__ import annotations

import importlib

#: topic -> module with ``run(quick) -> rows`` (or ``"module:function"``)
SPEED_TOPICS = {"cli": "vehicle_observers.bench.cli",
                "dmvt": "vehicle_observers_papers.ichalal_2011.speed",
                "estimators": "vehicle_observers.bench.estimators",
                "interval": "vehicle_observers_papers.ifqir_2017.speed",
                "kalman": "vehicle_observers_papers.leanza_2021.speed",
                "leaderboard": "vehicle_observers_papers.leanza_2021.leaderboard:speed_rows",
                "sliding_mode": "vehicle_observers_papers.rabhi_2004.speed",
                "uio": "vehicle_observers_papers.elyoussfi_2020.speed",
                "yacine": "vehicle_observers_papers.yacine_2015.speed"}


def topic_benchmarks(quick: bool = False, skip=()) -> list[dict]:
    """Run every ``run(quick)`` of :data:`SPEED_TOPICS` (topics in ``skip`` excepted) and tag
    the rows by topic; a failing topic gives one ``FAILED`` row and the others still run."""
    rows = []
    for topic, path in sorted(SPEED_TOPICS.items()):
        if topic in skip:
            continue
        try:
            mod, _, fn = path.partition(":")
            run = getattr(importlib.import_module(mod), fn or "run")
            for r in run(quick=quick):
                rows.append({"topic": topic, **r})
        except Exception as exc:  # noqa: BLE001 - one failing topic must not hide the rest
            rows.append({"topic": topic, "component": f"FAILED: {type(exc).__name__}: {exc}",
                         "steps": 0, "seconds": float("nan"), "us_per_step": float("nan")})
    return rows
