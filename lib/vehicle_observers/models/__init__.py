"""Vehicle, tyre and Takagi-Sugeno (sector-nonlinearity) models, and vehicle files."""
