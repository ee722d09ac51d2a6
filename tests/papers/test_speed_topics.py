"""Every paper's speed topic of ``make bench`` runs (quick mode) without a FAILED row: a topic
that raises is reported as one FAILED row by the benchmark, which would otherwise go unseen."""

import pytest
from vehicle_observers_papers.benchmark_study import speed as S

#: topics measured elsewhere in the suite (tests/bench) or that need the whole CLI
ELSEWHERE = ("cli", "estimators", "leaderboard")


@pytest.mark.parametrize("topic", [t for t in S.SPEED_TOPICS if t not in ELSEWHERE])
def test_speed_topic_runs(topic):
    rows = S.topic_benchmarks(quick=True, skip=tuple(t for t in S.SPEED_TOPICS if t != topic))
    assert rows, f"{topic}: no rows"
    failed = [r for r in rows if "FAILED" in str(r.values())]
    assert not failed, f"{topic}: {failed[0]}"
    assert all(r["topic"] == topic and r["seconds"] > 0 for r in rows)
