"""``python -m vehicle_observers.bench [--quick] [--plugin MODULE ...]``: the speed of every
registered estimator (:mod:`vehicle_observers.bench.estimators`) and of the command line end
to end (:mod:`vehicle_observers.bench.cli`). ``make bench`` runs them through the
reproductions' benchmark, ``python -m vehicle_observers_papers.benchmark_study``."""

import sys

from vehicle_observers.bench import cli, estimators
from vehicle_observers.results.tables import show_table


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    quick = "--quick" in argv
    rows = estimators.run(quick=quick, plugins=estimators.plugin_args(argv))
    print(estimators.table(rows, f"every registered estimator on the {estimators.VEHICLE} "
                                 f"sine with dwell ({rows[0]['steps'] if rows else 0} steps)"))
    print()
    cli_rows = cli.run(quick=quick)
    cols = [c for c in dict.fromkeys(k for r in cli_rows for k in r) if c != "cli_line"]
    print(show_table(cli_rows, cols, digits=3,
                     title="python -m vehicle_observers estimate, end to end"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
