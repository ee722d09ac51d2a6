"""``python -m vehicle_observers.bench [--quick] [--plugin MODULE|FILE.py ...] [--only NAME ...]
[--log LOG --vehicle VEHICLE]``: the speed of every registered estimator
(:mod:`vehicle_observers.bench.estimators`) and of the command line end to end
(:mod:`vehicle_observers.bench.cli`; skipped with ``--only``, which times only the estimators
named, e.g. one plug-in). ``make bench`` runs them through the reproductions' benchmark,
``python -m vehicle_observers_papers.benchmark_study``."""

import sys

from vehicle_observers.bench import cli, estimators
from vehicle_observers.results.tables import show_table


def main(argv=None) -> int:
    args = estimators.parse_args(sys.argv[1:] if argv is None else list(argv),
                                 "python -m vehicle_observers.bench")
    quick = args.quick
    only, log, vehicle = estimators.selection(args)
    rows = estimators.run(quick=quick, plugins=args.plugin, names=only, log=log,
                          vehicle=vehicle)
    where = log.source if log is not None else f"the {estimators.VEHICLE} sine with dwell"
    print(estimators.table(rows, f"{'the chosen' if only else 'every registered'} estimator(s) "
                                 f"on {where} ({rows[0]['steps'] if rows else 0} steps)"))
    if only:
        return 0
    print()
    cli_rows = cli.run(quick=quick)
    cols = [c for c in dict.fromkeys(k for r in cli_rows for k in r) if c != "cli_line"]
    print(show_table(cli_rows, cols, digits=3,
                     title="python -m vehicle_observers estimate, end to end"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
