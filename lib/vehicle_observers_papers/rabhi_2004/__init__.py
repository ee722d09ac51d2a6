"""Rabhi et al., AVCS 2004: sliding-mode observers of tyre forces and road profile (notebook 05)."""
