"""The core's configs with every value given, as these tests measure them. The dataclasses have no defaults (the
parameter schema's are the product's, through ``parameters.builders``); these are the values the tests' expected
figures were found with: a plain PID (the tutorial's clamp and measured-velocity D), no filter, no model terms."""

from robot_controller.core.controller import ControllerConfig
from robot_controller.core.estimation import KalmanConfig
from robot_controller.core.laws.pid import PidConfig
from robot_controller.core.model import SensorConfig

PID = {
    "kp": [50.0],
    "ki": [10.0],
    "kd": [5.0],
    "output_limit": [10.0],
    "integral_limit": [10.0],
    "anti_windup": "clamp",
    "back_calculation_time_s": 0.1,
    "derivative_source": "measured_velocity",
    "derivative_filter_time_s": 0.0,
    "slew_rate_limit": 0.0,
}
# The schema's filter as lockstep runs it (no command timing uncertainty).
KALMAN = {
    "position_noise_std": 0.005,
    "velocity_noise_std": 0.02,
    "acceleration_noise_std": 0.005,
    "disturbance_noise_std": 0.0001,
    "jump_detection_sigma": 5.0,
    "mismatch_acceleration_noise_std": 2.0,
    "mismatch_disturbance_noise_std": 0.3,
    "command_timing_uncertainty_s": 0.0,
}
SENSOR = {"position_noise_std": 0.005, "velocity_noise_std": 0.02, "position_bias": 0.0, "quantization": 0.0}
SENSOR |= {"delay_s": 0.0}
CONTROLLER = {
    "controller_type": "pid",
    "law_budget_s": 0.005,
    "law_error_max_rad": 0.5,
    "stop_law": "lqr",
    "lqr_q": (1e4, 1e4, 1.0),
    "lqr_r": 1e-2,
    "reference_inertia": 0.0,
    "rated_payload_kg": 0.0,
    "model_drive_lag_s": 0.0,
    "estimator": None,
    "disturbance_observer": False,
    "inertia_adaptation": False,
    "feedforward": "none",
    "feedback_decoupling": False,
    "control_period_s": 0.01,
    "reference_extrapolation": False,
    "latency_compensation": False,
    "world_waits": False,
    "watchdog_periods": 5,
    "sensor_timeout_s": 1.0,
    "max_reading_age_s": 0.1,
    "stop_deceleration": 20.0,
    "reacquire_acceleration": 20.0,
    "design_position": None,
    "min_delay_margin_periods": 1,
}


def pid(**values) -> PidConfig:
    return PidConfig(**(PID | values))


def kalman(**values) -> KalmanConfig:
    return KalmanConfig(**(KALMAN | values))


def sensor(**values) -> SensorConfig:
    return SensorConfig(**(SENSOR | values))


def controller(**values) -> ControllerConfig:
    return ControllerConfig(**({"pid": pid()} | CONTROLLER | values))
