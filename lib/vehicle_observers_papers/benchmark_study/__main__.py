"""``python -m vehicle_observers_papers.benchmark_study`` (``make bench``): the accuracy
benchmark, the speed benchmarks, the independent-plant study and the leaderboard
(:mod:`vehicle_observers_papers.leanza_2021.leaderboard`); writes ``build/benchmark/`` and
prints the tables. ``--plugin MODULE|FILE.py`` (repeatable) loads plug-ins like the command
line: their estimators join the accuracy study (beside :data:`runs.STUDY_ESTIMATORS`) and
the leaderboard, on every dataset that has the columns they read."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from vehicle_observers.data.logs import repo_root
from vehicle_observers.models.vehicle import load_vehicle

from vehicle_observers_papers.benchmark_study import plant_study, runs, speed, writers
from vehicle_observers_papers.leanza_2021 import leaderboard as LB


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m vehicle_observers_papers.benchmark_study")
    ap.add_argument("--quick", action="store_true", help="short runs (CI)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default=str(repo_root() / "build" / "benchmark"),
                    help="output folder (default build/benchmark, ignored by git: wall-clock "
                    "results change on every run)")
    ap.add_argument("--no-topics", action="store_true", help="skip the speed benchmarks")
    ap.add_argument("--no-leaderboard", action="store_true", help="skip the leaderboard")
    ap.add_argument("--plugin", action="append", default=[], metavar="MODULE|FILE.py",
                    help="load a plug-in: its estimators join the study and the leaderboard")
    ap.add_argument("--no-cli-speed", action="store_true",
                    help="skip the command-line wall times on the Revs log")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    from vehicle_observers.estimation import registry

    before = set(registry.available())
    added = [n for n in registry.available(args.plugin) if n not in before]
    res = runs.run(seed=args.seed, quick=args.quick,
                   observers=(*runs.STUDY_ESTIMATORS, *added) if added else None,
                   progress=lambda s: print(f"  running {s}", file=sys.stderr, flush=True))
    topics = None if args.no_topics else speed.topic_benchmarks(args.quick)
    board = None
    if not args.no_leaderboard:
        table, lb_errors = LB.rows(LB.datasets(args.quick, seed=args.seed, cars=(1, 2, 3),
                                               cross=True, emulated=True),
                                   progress=lambda s: print(f"  leaderboard {s}",
                                                            file=sys.stderr, flush=True))
        cost = [r["us_per_step"] for r in topics or () if r["topic"] == "leaderboard"]
        board = (table, LB.targets(table, cost[0] if cost else None), lb_errors)
    paths = writers.write_outputs(res, Path(args.out), topics, board)
    print(writers.markdown_table(res["rows"], writers.summary_columns()))
    if topics:
        print()
        print(writers.markdown_table(topics, writers.SPEED_COLUMNS))
    for e in res["errors"]:
        print("error:", e)
    km = runs.key_metrics(res)
    rv = {o: km.get(f"revs.{o}.rmse_vy") for o in ("ekf", "rts")}
    best = (km["revs.best_causal"], km["revs.best_causal_rmse_vy"]) \
        if "revs.best_causal" in km else None
    revs_diag = None
    if "revs" in res["logs"] and "revs" in res["tunings"]:
        revs_diag = plant_study.rts_diagnosis(res["logs"]["revs"],
                                              load_vehicle("revs250lm").params,
                                              res["tunings"]["revs"][0], seed=args.seed)
    section = plant_study.plant_section(args.seed, args.quick, best, rv["rts"], rv["ekf"],
                                        revs_diag=revs_diag)
    writers.print_plant_section(section)
    if board is not None:
        print("\n## Leaderboard (build/benchmark/leaderboard.md)\n")
        print(LB.markdown(board[0], LB.TABLE_COLUMNS))
        print()
        print(LB.markdown([{**t, "met": "met" if t["met"] else "MISSED"} for t in board[1]],
                          ("dataset", "target", "value", "limit", "met", "detail")))
    if not args.no_cli_speed:
        print("\n## Command line on the Revs log: warm wall time per estimator / the EKF's\n")
        print(LB.markdown(LB.cli_speed(), ("observer", "cold_s", "warm_s", "ratio_to_ekf",
                                           "limit", "met", "error")))
    print(f"\nwrote {', '.join(str(p) for p in paths)} in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
