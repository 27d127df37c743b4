"""The state estimate: the Kalman filter over every joint and its disturbance observer."""
