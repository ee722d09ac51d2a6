"""Paper-specific constants, one module per paper, each tested against the printed numbers."""
