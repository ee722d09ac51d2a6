"""The robustness campaigns of notebook 08: specs, the determinism check and the key metrics."""
