"""``python -m vehicle_observers.bench``: speed of the command line end to end (``make bench``
runs it after the reproductions' benchmark, ``python -m vehicle_observers_papers.benchmark_study``)."""

import sys

from vehicle_observers.bench.cli import run

if __name__ == "__main__":
    for row in run(quick="--quick" in sys.argv):
        print({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in row.items()})
