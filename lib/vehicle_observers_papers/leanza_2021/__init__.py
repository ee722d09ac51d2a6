"""Leanza, Reina, Blanco-Claraco, Sensors 2021: the Revs 250 LM log and its constants (notebooks 01, 07)."""
