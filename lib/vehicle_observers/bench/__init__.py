"""Speed of every registered estimator and of the command line (accuracy: vehicle_observers_papers)."""
