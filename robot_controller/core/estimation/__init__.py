"""The state estimate: the Kalman filter over every joint and its disturbance observer with its
process noise (:mod:`.kalman`), its tuning (:mod:`.config`), what it makes of a reading that
surprises it (:mod:`.innovation`), and one joint's filter at rest on the linear arm (:mod:`.linear`)."""

from robot_controller.core.estimation.config import DISTURBANCE_PRIOR_STD_NM, KalmanConfig
from robot_controller.core.estimation.kalman import JointKalmanFilter, MassMatrix, inverse_2x2, process_noise
from robot_controller.core.estimation.linear import steady_state_gain

__all__ = [
    "DISTURBANCE_PRIOR_STD_NM",
    "JointKalmanFilter",
    "KalmanConfig",
    "MassMatrix",
    "inverse_2x2",
    "process_noise",
    "steady_state_gain",
]
