"""Registry adapters for observers implemented in other modules (filled as they land)."""
