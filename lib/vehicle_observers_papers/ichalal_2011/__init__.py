"""Ichalal et al., MED 2011: autonomous bicycle, DMVT observer with LMI pole regions (notebooks 01, 04)."""
