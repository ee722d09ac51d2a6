"""Yacine, Ichalal, Mammar et al., IEEE TCST 2015: TS observer with estimated premises (notebooks 01, 02)."""
