"""Reproductions of the five papers, beside the library ``vehicle_observers`` (never inside it).

One folder per paper, ``<author>_<year>``, each with the paper's printed constants
(``constants``), its experiments, metric tables and figures (one module per notebook
section) and its speed benchmark (``speed``); ``benchmark_study`` is the estimator benchmark
of notebook 07 (every observer against the Kalman baselines on the same data). The library
never imports this package (``tests/test_architecture.py``).
"""
