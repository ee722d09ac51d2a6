"""Drive logs (schema and validated loader), scenario generators, road profiles, identification."""
