"""El Youssfi et al. line of work, 2020: relaxed unknown-input observer, fault estimation (notebook 06)."""
