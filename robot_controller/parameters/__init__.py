"""Parameters of every node: schema (type, description, limits), loading of
ROS parameter files, presets, validation and building core configs.

Values live in ``config/stack.yaml`` (ROS parameter-file format); this module
holds what each parameter means and what values it accepts, in one place for
the nodes, the launcher and the in-process loop. No rclpy here.
"""
from __future__ import annotations

import array
import difflib
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import yaml

from robot_controller import resources
from robot_controller.core.errors import ConfigError
from robot_controller.core.feedforward import FeedforwardMode
from robot_controller.core.pid import AntiWindup, DerivativeSource, PidConfig
from robot_controller.core.sensor_model import SensorConfig
from robot_controller.core.trajectory import MODES

if TYPE_CHECKING:  # the controller pulls in scipy and MuJoCo: only the nodes that run one import it
    from robot_controller.core.controller import ControllerConfig

NODES = ("simulator", "motor_node", "sensor_node", "pid_controller", "trajectory_planner")
# Parameters rclpy declares on every node by itself.
ROS_BUILTIN = ("use_sim_time",)


@dataclass(frozen=True)
class ParamSpec:
    """One parameter: ``kind`` is bool, int, float, str or ``"floats"`` (a
    number or a list of numbers: one per joint, or one for all)."""

    name: str
    kind: Any
    description: str
    minimum: float | None = None
    exclusive_minimum: bool = False
    maximum: float | None = None
    choices: tuple[str, ...] | None = None
    read_only: bool = False

    def describe(self) -> str:
        rules = []
        if self.minimum is not None:
            rules.append(f"{'>' if self.exclusive_minimum else '>='} {self.minimum:g}")
        if self.maximum is not None:
            rules.append(f"<= {self.maximum:g}")
        if self.choices:
            rules.append("one of " + ", ".join(self.choices))
        return self.description + (f" [{'; '.join(rules)}]" if rules else "")

    def validate(self, value: Any) -> Any:
        """Return the value normalised (floats as float, lists as list of float) or raise ConfigError."""
        kind = self.kind
        if kind is bool:
            if not isinstance(value, bool):
                raise ConfigError(f"{self.name}: expected true or false, got {value!r}")
            return value
        if kind is str:
            if not isinstance(value, str):
                raise ConfigError(f"{self.name}: expected a string, got {value!r}")
            if self.choices and value not in self.choices:
                hint = difflib.get_close_matches(value, self.choices, n=1)
                raise ConfigError(f"{self.name}: {value!r} is not one of {list(self.choices)}"
                                  + (f" (did you mean {hint[0]!r}?)" if hint else ""))
            return value
        if kind is int:
            if isinstance(value, bool) or not isinstance(value, int):
                raise ConfigError(f"{self.name}: expected an integer, got {value!r}")
            self._check_range(value)
            return value
        if kind is float:
            return self._number(value)
        if kind == "floats":
            if isinstance(value, (list, tuple, array.array, np.ndarray)):  # rclpy gives array('d')
                if len(value) == 0:
                    raise ConfigError(f"{self.name}: expected a number or a non-empty list of numbers")
                return [self._number(v) for v in value]
            return self._number(value)
        raise AssertionError(kind)

    def _number(self, value: Any) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"{self.name}: expected a number, got {value!r}")
        value = float(value)
        if not math.isfinite(value):
            raise ConfigError(f"{self.name}: must be finite, got {value}")
        self._check_range(value)
        return value

    def _check_range(self, value: float) -> None:
        if self.minimum is not None:
            if value < self.minimum or (self.exclusive_minimum and value == self.minimum):
                op = ">" if self.exclusive_minimum else ">="
                raise ConfigError(f"{self.name}: must be {op} {self.minimum:g}, got {value:g}")
        if self.maximum is not None and value > self.maximum:
            raise ConfigError(f"{self.name}: must be <= {self.maximum:g}, got {value:g}")


def _positive(name: str, description: str, kind: Any = float) -> ParamSpec:
    return ParamSpec(name, kind, description, minimum=0.0, exclusive_minimum=True)


def _rate(name: str, description: str, low: float, high: float) -> ParamSpec:
    """A rate in Hz within what this stack can keep (a rate beyond it starves the
    loop; one below it leaves the watchdog with nothing to watch)."""
    return ParamSpec(name, float, description, minimum=low, maximum=high)


def _nonneg(name: str, description: str, kind: Any = float) -> ParamSpec:
    return ParamSpec(name, kind, description, minimum=0.0)


URDF = ParamSpec("urdf_path", str, "robot description (URDF file); empty means the package's reference arm",
                 read_only=True)

SCHEMA: dict[str, tuple[ParamSpec, ...]] = {
    "simulator": (
        URDF,
        _rate("physics_rate_hz", "physics steps per second (MuJoCo)", 100.0, 10000.0),
        _rate("publish_rate_hz", "rate of /sim/joint_states (true state), Hz; a whole divisor of physics_rate_hz",
              10.0, 1000.0),
        ParamSpec("initial_position", "floats", "initial joint position, rad (one per joint, or one for all)"),
        ParamSpec("wait_for_first_command", bool,
                  "keep the arm still (brakes on) until the first effort arrives, so start-up order does not matter"),
        ParamSpec("lockstep", bool, "sim-time lockstep: publish /clock and advance one control period per effort",
                  read_only=True),
        _rate("control_rate_hz", "control rate the lockstep advances by (one period per effort), Hz", 10.0, 1000.0),
        _positive("drive_timeout_s", "efforts missing this long (wall clock) engage the holding brakes and cut "
                  "the torque (category 0), s"),
        _positive("brake_torque_nm", "holding torque of each joint's brake, N·m (stops the reference arm from "
                  "3 rad/s in about 5 ms)"),
    ),
    "motor_node": (
        URDF,
        ParamSpec("torque_max", "floats", "actuator torque limit, N·m (one per joint, or one for all)",
                  minimum=0.0, exclusive_minimum=True),
        _nonneg("lag_time_constant_s", "first-order actuator lag time constant, s (0 = none)"),
        _positive("command_timeout_s", "no valid /joint_commands for this long: zero torque and brake request "
                  "(category 0) until commands return, s"),
    ),
    "sensor_node": (
        _rate("rate_hz", "sensor sample rate, Hz", 10.0, 1000.0),
        _nonneg("position_noise_std", "Gaussian position noise σ, rad"),
        _nonneg("velocity_noise_std", "Gaussian velocity noise σ, rad/s"),
        ParamSpec("position_bias", float, "constant position bias, rad"),
        _nonneg("quantization", "position quantisation step, rad (0 = none)"),
        ParamSpec("seed", int, "random seed of the noise; -1 draws one from the OS", minimum=-1),
        ParamSpec("delay_s", float, "each reading is published this late, stamped with its sample time, s "
                  "(a slow encoder or bus)", minimum=0.0, maximum=1.0),
    ),
    "pid_controller": (
        URDF,
        ParamSpec("controller_type", str, "control law behind the node: PID with the gains below, or LQR "
                  "(gains from a discrete Riccati design with lqr_q and lqr_r)", choices=("pid", "lqr")),
        ParamSpec("lqr_q", "floats", "LQR state weights on [∫error, error, velocity error]", minimum=0.0),
        _positive("lqr_r", "LQR weight on the feedback torque"),
        ParamSpec("estimator", str, "state estimate the law acts on: the raw reading, or a Kalman filter on "
                  "position and velocity with the applied torque as input", choices=("none", "kalman")),
        _positive("kalman_position_noise_std", "Kalman filter: encoder position noise σ, rad"),
        _positive("kalman_velocity_noise_std", "Kalman filter: encoder velocity noise σ, rad/s"),
        _positive("kalman_acceleration_noise_std", "Kalman filter: unmodelled acceleration σ, rad/s²"),
        _rate("control_rate_hz", "control loop rate, Hz", 10.0, 1000.0),
        ParamSpec("trigger", str, "what starts a control step: a timer at control_rate_hz (the tutorial's way) "
                  "or each new sensor reading (read-update-write, no phase delay; a timer still runs the "
                  "watchdog)", choices=("timer", "measurement")),
        ParamSpec("kp", "floats", "proportional gain, N·m/rad", minimum=0.0),
        ParamSpec("ki", "floats", "integral gain, N·m/(rad·s)", minimum=0.0),
        ParamSpec("kd", "floats", "derivative gain, N·m·s/rad", minimum=0.0),
        ParamSpec("integral_limit", "floats", "clamp on the integral of the error, rad·s (anti_windup clamp)",
                  minimum=0.0),
        ParamSpec("anti_windup", str, "anti-windup mode", choices=tuple(m.value for m in AntiWindup)),
        _positive("back_calculation_time_s", "tracking time constant of back-calculation anti-windup, s"),
        ParamSpec("derivative_source", str, "what the D term differentiates",
                  choices=tuple(m.value for m in DerivativeSource)),
        _nonneg("derivative_filter_time_s", "first-order filter on the D term, s (0 = off)"),
        ParamSpec("feedforward", str, "model feedforward from the URDF",
                  choices=tuple(m.value for m in FeedforwardMode)),
        ParamSpec("torque_max", "floats", "output limit, N·m", minimum=0.0, exclusive_minimum=True),
        _nonneg("slew_rate_limit", "maximum rate of change of the command, N·m/s (0 = off)"),
        ParamSpec("reference_extrapolation", bool,
                  "evaluate the latest reference at the tick time with its velocity and acceleration"),
        ParamSpec("latency_compensation", bool,
                  "advance the measurement from its stamp to the tick time with its velocity"),
        ParamSpec("watchdog_periods", int, "control periods without valid sensor data before a controlled stop "
                  "on the arm model's estimate (category 2)", minimum=1),
        _positive("sensor_timeout_s", "readings missing this long end the controlled stop: no command, the "
                  "drive's brake holds (category 1), s"),
        _positive("max_reading_age_s", "a reading older than this when it arrives (or stamped this far in the "
                  "future) is dropped and does not count as a sign of life, s"),
        _positive("stop_deceleration", "deceleration of a controlled stop (sensor or planner lost), rad/s²"),
        _positive("reacquire_acceleration", "acceleration limit of the blend from where the arm is back onto "
                  "the trajectory after a fault, rad/s²"),
        _positive("log_period_s", "period of the target/actual/error/torque log line, s"),
        _positive("diagnostics_period_s", "period of the loop-health report on /diagnostics, s"),
        ParamSpec("lockstep", bool,
                  "compute on each measurement once the due reference is in (sim-time lockstep), not on a timer",
                  read_only=True),
    ),
    "trajectory_planner": (
        ParamSpec("mode", str, "reference shape", choices=MODES),
        ParamSpec("joint_count", int, "number of joints to plan for", minimum=1, read_only=True),
        ParamSpec("amplitude", "floats", "amplitude (sine, square, chirp) or step size, rad"),
        _nonneg("frequency_hz", "frequency of sine and square, start frequency of chirp, Hz"),
        ParamSpec("offset", "floats", "centre (sine, square, chirp), start (step) or hold position, rad"),
        _nonneg("step_time_s", "time of the step after the planner starts, s"),
        ParamSpec("step_shaping", str, "step as a jump, or shaped into the fastest move within max_acceleration "
                  "(bang-bang), which the arm can follow inside its torque limit", choices=("none", "min_time")),
        _positive("max_acceleration", "acceleration limit of a shaped step, rad/s² (the reference arm: "
                  "(10 − 2.45) N·m / 0.0833 kg·m² ≈ 90 at most; 60 leaves the feedback room)"),
        _nonneg("end_frequency_hz", "end frequency of the chirp, Hz"),
        _positive("sweep_time_s", "duration of one chirp sweep, s"),
        _rate("publish_rate_hz", "rate of /trajectory, Hz", 1.0, 1000.0),
        ParamSpec("lockstep", bool, "sample on /clock ticks (sim-time lockstep) instead of a timer",
                  read_only=True),
    ),
}

Params = dict[str, dict[str, Any]]


def spec_of(node: str, name: str) -> ParamSpec:
    for spec in SCHEMA[node]:
        if spec.name == name:
            return spec
    raise KeyError(f"{node}.{name}")


def _node_key(key: str) -> str:
    return key.lstrip("/")


def read_params_file(path: str | Path) -> Params:
    """Read a ROS 2 parameter file into ``{node: {param: value}}``, validated.

    ``/**`` entries apply to every node that has the parameter.

    :raises ConfigError: naming the file, the key and the problem
    """
    path = Path(path)
    try:
        raw = yaml.safe_load(path.read_text())
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such file") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML: {exc}") from None
    if raw is None:
        return {}
    if not isinstance(raw, dict):
        raise ConfigError(f"{path}: expected a mapping of node names to 'ros__parameters'")
    out: Params = {}
    for key, body in raw.items():
        node = _node_key(str(key))
        if node != "**" and node not in NODES:
            hint = difflib.get_close_matches(node, NODES, n=1)
            raise ConfigError(f"{path}: unknown node {key!r}; nodes are {list(NODES)}"
                              + (f" (did you mean {hint[0]!r}?)" if hint else ""))
        if not isinstance(body, dict) or set(body) != {"ros__parameters"} or not isinstance(
                body["ros__parameters"], dict):
            raise ConfigError(f"{path}: {key}: expected exactly one key 'ros__parameters' holding a mapping")
        for name, value in body["ros__parameters"].items():
            targets = [n for n in NODES if _has(n, name)] if node == "**" else [node]
            if node == "**" and not targets and name not in ROS_BUILTIN:
                raise ConfigError(f"{path}: /**.{name}: no node has a parameter {name!r}")
            for target in targets:
                out.setdefault(target, {})[name] = _validated(path, target, name, value)
            if node == "**" and name in ROS_BUILTIN:
                for target in NODES:
                    out.setdefault(target, {})[name] = value
    return out


def _has(node: str, name: str) -> bool:
    return any(spec.name == name for spec in SCHEMA[node])


def _validated(path: Path, node: str, name: str, value: Any) -> Any:
    if name in ROS_BUILTIN:
        if not isinstance(value, bool):
            raise ConfigError(f"{path}: {node}.{name}: expected true or false, got {value!r}")
        return value
    if not _has(node, name):
        names = [spec.name for spec in SCHEMA[node]]
        hint = difflib.get_close_matches(name, names, n=1)
        raise ConfigError(f"{path}: {node}.{name}: unknown parameter"
                          + (f" (did you mean {hint[0]!r}?)" if hint else f"; {node} has {names}"))
    try:
        return spec_of(node, name).validate(value)
    except ConfigError as exc:
        raise ConfigError(f"{path}: {node}.{exc}") from None


def merge(*layers: Params) -> Params:
    out: Params = {}
    for layer in layers:
        for node, values in layer.items():
            out.setdefault(node, {}).update(values)
    return out


def load_stack(preset: str = "default", config: str | Path | None = None) -> Params:
    """Defaults from ``stack.yaml``, then the preset's overlay, then the user's file."""
    layers = [read_params_file(resources.stack_yaml())]
    if preset != "default":
        preset_path = resources.preset_yaml(preset)
        if not preset_path.is_file():
            raise ConfigError(f"--preset: unknown preset {preset!r}; presets are {available_presets()}")
        layers.append(read_params_file(preset_path))
    if config is not None:
        layers.append(read_params_file(config))
    params = merge(*layers)
    check_complete(params)
    return params


def available_presets() -> list[str]:
    folder = resources.stack_yaml().parent / "presets"
    return ["default"] + sorted(p.stem for p in folder.glob("*.yaml"))


def check_complete(params: Params) -> None:
    for node in NODES:
        missing = [spec.name for spec in SCHEMA[node] if spec.name not in params.get(node, {})]
        if missing:
            raise ConfigError(f"{node}: no value for {missing}")


def write_params_file(params: Params, path: str | Path) -> Path:
    """Write ``params`` as a ROS 2 parameter file that ``--params-file`` reads."""
    path = Path(path)
    body = {node: {"ros__parameters": dict(values)} for node, values in params.items()}
    path.write_text(yaml.safe_dump(body, sort_keys=False))
    return path


# --- Building core configs from parameter values -----------------------------

def per_joint(name: str, value: float | list[float], joint_count: int) -> np.ndarray:
    array = np.atleast_1d(np.asarray(value, dtype=float))
    if array.size == 1:
        return np.full(joint_count, float(array[0]))
    if array.size != joint_count:
        expected = "1 value" if joint_count == 1 else f"1 or {joint_count} values (one per joint)"
        raise ConfigError(f"{name}: expected {expected}, got {array.size}")
    return array


def controller_config(values: Mapping[str, Any], joint_count: int) -> ControllerConfig:
    from robot_controller.core.controller import ControllerConfig
    from robot_controller.core.estimator import KalmanConfig

    def joints(name: str) -> np.ndarray:
        return per_joint(name, values[name], joint_count)

    pid = PidConfig(
        kp=joints("kp"), ki=joints("ki"), kd=joints("kd"),
        output_limit=joints("torque_max"), integral_limit=joints("integral_limit"),
        anti_windup=values["anti_windup"], back_calculation_time_s=values["back_calculation_time_s"],
        derivative_source=values["derivative_source"],
        derivative_filter_time_s=values["derivative_filter_time_s"],
        slew_rate_limit=values["slew_rate_limit"],
    )
    q = np.atleast_1d(np.asarray(values["lqr_q"], dtype=float))
    if q.shape != (3,):
        raise ConfigError(f"lqr_q: expected 3 weights (integral, position, velocity), got {q.size}")
    estimator = None
    if values["estimator"] == "kalman":
        estimator = KalmanConfig(values["kalman_position_noise_std"], values["kalman_velocity_noise_std"],
                                 values["kalman_acceleration_noise_std"])
    return ControllerConfig(
        pid=pid, law=values["controller_type"], lqr_q=tuple(q.tolist()), lqr_r=values["lqr_r"], estimator=estimator,
        feedforward=values["feedforward"], control_period_s=1.0 / values["control_rate_hz"],
        reference_extrapolation=values["reference_extrapolation"],
        latency_compensation=values["latency_compensation"], watchdog_periods=values["watchdog_periods"],
        sensor_timeout_s=values["sensor_timeout_s"], max_reading_age_s=values["max_reading_age_s"],
        stop_deceleration=values["stop_deceleration"],
        reacquire_acceleration=values["reacquire_acceleration"],
    )


def sensor_config(values: Mapping[str, Any]) -> SensorConfig:
    return SensorConfig(position_noise_std=values["position_noise_std"],
                        velocity_noise_std=values["velocity_noise_std"],
                        position_bias=values["position_bias"], quantization=values["quantization"],
                        delay_s=values["delay_s"])


def trajectory_kwargs(values: Mapping[str, Any]) -> dict[str, Any]:
    keys = ("amplitude", "frequency_hz", "offset", "step_time_s", "end_frequency_hz", "sweep_time_s", "step_shaping",
            "max_acceleration")
    return {"joint_count": values["joint_count"], "sample_period_s": 1.0 / values["publish_rate_hz"],
            **{k: values[k] for k in keys}}
