"""The estimator benchmark of notebook 07: every observer against the Kalman baselines on the same data."""
