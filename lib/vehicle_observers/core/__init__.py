"""Foundations without vehicle knowledge: errors, error metrics, signals, array and timing helpers."""
