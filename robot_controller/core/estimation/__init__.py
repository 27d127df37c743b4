"""The state estimate: the Kalman filter over every joint and its disturbance observer with its
process noise (:mod:`.kalman`), its tuning (:mod:`.config`), what it makes of a reading that
surprises it (:mod:`.innovation`), and one joint's filter at rest on the linear arm (:mod:`.linear`)."""

from robot_controller.core.estimation.config import KalmanConfig
from robot_controller.core.estimation.innovation import inverse_2x2
from robot_controller.core.estimation.kalman import JointKalmanFilter
from robot_controller.core.estimation.linear import steady_state_gain
from robot_controller.core.estimation.process_noise import process_noise

__all__ = [
    "JointKalmanFilter",
    "KalmanConfig",
    "inverse_2x2",
    "process_noise",
    "steady_state_gain",
]
