"""``python -m vehicle_observers_papers.benchmark_study``: accuracy and speed benchmark (``make bench``)."""

from vehicle_observers_papers.benchmark_study.suite import main

if __name__ == "__main__":
    raise SystemExit(main())
