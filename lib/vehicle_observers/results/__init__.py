"""Reporting: figures, metrics.json and claims, plotting helpers, the papermill pipeline."""
