"""Speed and accuracy benchmark (make bench) and the per-topic speed benchmarks."""
