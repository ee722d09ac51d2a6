"""Kalman baselines: EKF/UKF/RTS on the lateral model and the filterpy EKF set against each observer."""
