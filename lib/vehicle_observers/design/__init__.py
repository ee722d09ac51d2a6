"""LMI synthesis with an independent eigenvalue certificate, and LMI pole regions."""
