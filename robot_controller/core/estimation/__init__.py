"""The state estimate: the Kalman filter over every joint and its disturbance observer, its
tuning, what it makes of each reading's surprise, and its linearisation."""

from robot_controller.core.estimation.config import DISTURBANCE_PRIOR_STD_NM, KalmanConfig, process_noise
from robot_controller.core.estimation.kalman import JointKalmanFilter, MassMatrix, StepJacobian, inverse_2x2
from robot_controller.core.estimation.linear import Predictor, steady_state_gain

__all__ = [
    "DISTURBANCE_PRIOR_STD_NM",
    "JointKalmanFilter",
    "KalmanConfig",
    "MassMatrix",
    "Predictor",
    "StepJacobian",
    "inverse_2x2",
    "process_noise",
    "steady_state_gain",
]
