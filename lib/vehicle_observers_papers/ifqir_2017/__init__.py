"""Ifqir et al., GTAA 2017: switched TS interval observer with uncertain cornering stiffness (notebook 03)."""
