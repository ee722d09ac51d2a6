"""The estimator benchmark of notebook 07: every registered observer against the Kalman
baselines on the same data (``make bench`` = ``python -m vehicle_observers_papers.benchmark_study``;
notebook 07 shows the same tables and plots).

Modules
    :mod:`.runs`
        The benchmark runs: the datasets, every registry entry on each, scores, ratios
        against the EKF and the RTS smoother, flat metrics, where the estimators lose on the
        real log.
    :mod:`.plant_study`
        The independent-plant study (CommonRoad multi-body plant, model mismatched): rows,
        targets, the smoother diagnosis, the interval observer's certification for every car.
    :mod:`.speed`
        The speed benchmarks of the library (:mod:`vehicle_observers.bench`: every registered
        estimator, the command line end to end) and of each reproduction (``speed``).
    :mod:`.figures`
        The plots (palette: :mod:`vehicle_observers.results.plotting`).
    :mod:`.writers`
        Markdown tables, CSV, ``metrics.json`` and the output folder of ``make bench``.
    ``__main__``
        ``main``: runs everything, writes ``build/benchmark/`` and prints the tables.

Protocol
    Datasets (:func:`.runs.datasets`): ``satory_n1`` / ``satory_n3``, the emulated Satory run
    (:func:`vehicle_observers.data.scenarios.emulated_satory`) at sensor-noise scale 1 and 3;
    ``swd``, a sine with dwell at 17 m/s reaching ~7 deg front slip (nonlinear tyre region,
    :func:`~vehicle_observers.data.scenarios.sine_with_dwell`); ``revs``, the real Revs 250 LM
    log (INS ``v_y`` as reference). Emulated runs use the ``yacine2015`` vehicle file, the real
    log ``revs250lm``.

    Observers: every registry entry whose required columns the dataset has. The filterpy EKF
    and UKF (pure Python, ~0.1-1 ms per step) run on ``filterpy_steps`` samples only, starting
    at the first scored sample; their rows say so (``samples`` column), their accuracy is over
    that window and they get no ratio against the whole-run EKF/RTS.

    Kalman noise tuning: ML on the measured channels of each log's first 120 s
    (:func:`vehicle_observers.estimation.kalman_runs.kalman_tuning`); the 7 s sine with dwell
    is too short for ML and reuses the tuning of the Satory run with the same noise level (same
    car and sensors).

    Metrics (:func:`vehicle_observers.estimation.score`): RMSE / max error of ``v_y``,
    sideslip, yaw rate (against the noise-free yaw rate in emulated logs, the measured one on
    the real log), axle forces where the log has them; interval enclosure and mean width.
    Emulated runs are scored where ``v_x > 1 m/s`` and ``t > 1 s`` (the run starts from
    0.2 m/s where every model is singular); the real log on every sample. Cost per step = wall
    time of the estimation loop (compiled, after a warm-up) / samples; real-time factor = log
    duration / wall time; design time = LMI solve (or ML tuning for the Kalman filters).
    Ratios: ``rmse_vy`` / that of ``ekf`` and of ``rts`` on the same dataset; speed-up =
    filterpy EKF cost per step / the observer's.

Outputs of ``make bench`` in ``build/benchmark/`` (ignored by git: wall-clock values change on
every run): ``benchmark.csv``, ``benchmark.md``, ``speed_topics.csv`` (:mod:`.speed`),
``losses_revs.csv`` (where each estimator loses on the real log), ``metrics.json`` and PNG
plots.
"""
