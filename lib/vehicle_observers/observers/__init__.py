"""State observers, one module per observer kind (each cites the paper it implements), and differentiators."""
