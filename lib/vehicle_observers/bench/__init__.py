"""Speed of the command line end to end (the accuracy and per-paper benchmark: vehicle_observers_papers)."""
