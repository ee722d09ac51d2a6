"""The reproductions (not library code): each paper's printed constants and each notebook's experiments."""
