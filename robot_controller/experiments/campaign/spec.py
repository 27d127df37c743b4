"""A campaign's spec: the YAML file read and checked whole before any run (a bad key is refused naming the key and
the reason), with the stack it varies loaded once; and run k's draws, from the campaign's seed and k alone: the same
wherever and whenever run k runs, and the same for every controller compared. Each varied key draws from a stream of
its own, so adding a key leaves the others'.

.. code-block:: yaml

    robot: one_dof
    controller: lqr                  # a built-in law, an installed one, or path/to/file.py:Class
    config: my_arm.yaml              # optional: a parameter file over the robot's defaults
    duration_s: 10
    runs: 200
    seed: 1
    run_timeout_s: 160               # optional: a run's wall-time limit (default 60 s + 10 x duration_s)
    identify: true                   # optional: each world identified before its run, as its user would
    tune: tracking                   # optional, with identify: and tuned for tracking, robust or effort
    vary:
      sensor_node.delay_s: {uniform: [0.0, 0.02]}
      sensor_node.position_noise_std: {loguniform: [0.001, 0.01]}
      simulator.joint_friction_nm: {uniform: [0.0, 1.5], per_joint: true}
    pass:
      tracking_rms_rad: 0.005
"""

from __future__ import annotations

import difflib
import math
import zlib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from robot_controller import parameters as cfg
from robot_controller.core.errors import ConfigError
from robot_controller.experiments import laws

KINDS = ("uniform", "normal", "loguniform", "choice")
TOP_KEYS = (
    "robot", "controller", "config", "duration_s", "runs", "seed", "vary", "pass", "run_timeout_s", "identify", "tune",
)  # fmt: skip
#: A run's wall-time limit when the spec gives none: this, plus RUN_TIMEOUT_PER_S per simulated second. A 10 s run of
#: the reference arm takes about 0.7 s of a core, the Panda's a few: the default is far beyond a sound run on a
#: busy host, and a run past it is stuck.
RUN_TIMEOUT_BASE_S = 60.0
RUN_TIMEOUT_PER_S = 10.0
#: What a campaign sets itself: a draw of these would be overwritten (or would make the run another experiment).
NOT_VARIED = {"sensor_node.seed": "each run's noise seed is derived from the campaign's seed and its run id"}
#: The figures each run's row holds (executors.in_process_row), in the report's order: ``pass:`` may bound them.
FIGURES = (
    "tracking_rms_rad",
    "tracking_max_rad",
    "start_tracking_max_rad",
    "tracking_rms_m",
    "tracking_max_m",
    "start_tracking_max_m",
    "peak_effort_ratio",
    "saturated_ticks",
    "faults",
)


@dataclass(frozen=True)
class Vary:
    """One varied parameter: ``key`` (``node.parameter``) drawn from ``kind`` with ``args``."""

    key: str
    kind: str
    args: tuple  #: (lo, hi) for uniform and loguniform, (mean, sd) for normal, the values for choice
    per_joint: bool = False
    minimum: float | None = None  #: the parameter's own bounds: a normal draw is clipped to them
    maximum: float | None = None


@dataclass(frozen=True)
class CampaignSpec:
    robot: str
    controller: str | None  #: as pid_controller's controller_type takes it (a file's path absolute); None: the config's
    config: Path | None
    duration_s: float
    runs: int
    seed: int
    vary: tuple[Vary, ...]
    pass_bounds: dict[str, float] = field(default_factory=dict)
    joint_count: int = 1
    text: str = ""  #: the file as read (kept beside the results)
    path: Path = Path("campaign.yaml")  #: where it was read (a relative config is beside it)
    run_timeout_s: float | None = None  #: a run's wall-time limit, s (None: the default, :attr:`timeout_s`)
    identify: bool = False  #: each world identified before its run (``identify`` in process)
    tune: str = ""  #: with ``identify``, each world's gains then designed for this target and verified ("": not)

    @property
    def timeout_s(self) -> float:
        """A run's wall-time limit, s: past it, its process is killed (the run is recorded as timed out)."""
        if self.run_timeout_s is not None:
            return self.run_timeout_s
        return RUN_TIMEOUT_BASE_S + RUN_TIMEOUT_PER_S * self.duration_s

    def base_params(self, controller: str | None = None) -> cfg.Params:
        """The stack every run starts from: the robot's, the config over it, the controller (``controller`` or the
        spec's)."""
        params = cfg.load_stack("default", [self.config] if self.config else None, self.robot)
        return laws.with_controller(params, controller or self.controller)


def load_spec(path: str | Path) -> CampaignSpec:
    """Read and check ``path``: every refusal names the file, the key and the reason.

    :raises ConfigError: the first problem found
    """
    path = Path(path)
    try:
        text = path.read_text()
        raw = yaml.safe_load(text)
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise ConfigError(f"{path}: is a directory, not a campaign spec") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML: {exc}") from None
    return parse_spec(raw, path, text)


def parse_spec(raw: Any, path: Path, text: str = "") -> CampaignSpec:
    def refuse(key: str, why: str) -> ConfigError:
        return ConfigError(f"{path}: {key}: {why}")

    if not isinstance(raw, dict):
        raise ConfigError(f"{path}: expected a mapping with {', '.join(TOP_KEYS)}")
    for key in raw:
        if key not in TOP_KEYS:
            hint = difflib.get_close_matches(str(key), TOP_KEYS, n=1)
            raise refuse(
                str(key), "unknown key" + (f" (did you mean {hint[0]!r}?)" if hint else f"; keys are {TOP_KEYS}")
            )
    for key in ("robot", "duration_s", "runs", "vary"):
        if key not in raw:
            raise refuse(key, "missing")
    robot = raw["robot"]
    if not isinstance(robot, str):
        raise refuse("robot", f"expected a robot's name, got {robot!r}")
    if robot.endswith(".urdf") and (path.parent / robot).is_file():  # a URDF beside the spec, as its config is
        robot = str((path.parent / robot).resolve())
    duration_s = raw["duration_s"]
    if isinstance(duration_s, bool) or not isinstance(duration_s, (int, float)) or not 0 < duration_s < math.inf:
        raise refuse("duration_s", f"expected seconds > 0, got {duration_s!r}")
    runs, seed = raw["runs"], raw.get("seed", 0)
    if isinstance(runs, bool) or not isinstance(runs, int) or runs < 1:
        raise refuse("runs", f"expected a whole number >= 1, got {runs!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise refuse("seed", f"expected a whole number >= 0, got {seed!r}")
    config = raw.get("config")
    if config is not None:
        if not isinstance(config, str):
            raise refuse("config", f"expected a parameter file's path, got {config!r}")
        config = (path.parent / config).resolve()
        if not config.is_file():
            raise refuse("config", f"{config}: no such file")
    controller = raw.get("controller")
    if controller is not None:
        controller = laws.controller_type(controller, path.parent, f"{path}: controller")
    spec = CampaignSpec(robot, controller, config, float(duration_s), runs, seed, ())
    try:
        params = spec.base_params()  # the robot, the config file and the law: each refused in its own words
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None
    joint_count = int(params["trajectory_planner"]["joint_count"])
    varied = raw["vary"]
    if not isinstance(varied, dict) or not varied:
        raise refuse("vary", "expected a mapping of node.parameter to a distribution, e.g. {uniform: [0, 0.01]}")
    vary = tuple(_vary(str(key), body, refuse) for key, body in varied.items())
    timeout_s = raw.get("run_timeout_s")
    if timeout_s is not None and not (_is_number(timeout_s) and timeout_s > 0):
        raise refuse("run_timeout_s", f"expected a run's wall-time limit, seconds > 0, got {timeout_s!r}")
    spec = replace(spec, vary=vary, pass_bounds=_pass_bounds(raw.get("pass"), refuse), joint_count=joint_count)
    spec = replace(spec, **_preparation(raw, refuse))
    return replace(spec, text=text, path=path.resolve(), run_timeout_s=None if timeout_s is None else float(timeout_s))


def _vary(key: str, body: Any, refuse) -> Vary:
    node, _, name = key.partition(".")
    if node not in cfg.NODES or not name:
        hint = difflib.get_close_matches(node, cfg.NODES, n=1)
        why = f"expected node.parameter with a node of {list(cfg.NODES)}" + (
            f" (did you mean {hint[0]!r}?)" if hint else ""
        )
        raise refuse(f"vary.{key}", why)
    if not cfg.has(node, name):
        names = [s.name for s in cfg.SCHEMA[node]]
        hint = difflib.get_close_matches(name, names, n=1)
        why = "unknown parameter" + (f" (did you mean {node}.{hint[0]}?)" if hint else f"; {node} has {names}")
        raise refuse(f"vary.{key}", why)
    if key in NOT_VARIED:
        raise refuse(f"vary.{key}", f"not varied: {NOT_VARIED[key]}")
    where = f"vary.{key}"
    if not isinstance(body, dict):
        raise refuse(where, f"expected one of {{{': ..., '.join(KINDS)}: ...}}, got {body!r}")
    kinds = [k for k in body if k in KINDS]
    extra = [k for k in body if k not in (*KINDS, "per_joint")]
    if len(kinds) != 1 or extra:
        raise refuse(where, f"expected exactly one of {', '.join(KINDS)} (and optionally per_joint), got {list(body)}")
    kind, per_joint = kinds[0], body.get("per_joint", False)
    spec = cfg.spec_of(node, name)
    if not isinstance(per_joint, bool):
        raise refuse(f"{where}.per_joint", f"expected true or false, got {per_joint!r}")
    if per_joint and not spec.per_joint:
        raise refuse(f"{where}.per_joint", f"{key} is one value for the whole arm, not one per joint")
    args = body[kind]
    if kind == "choice":
        if not isinstance(args, list) or not args:
            raise refuse(f"{where}.choice", f"expected a non-empty list of values, got {args!r}")
        for value in args:
            _check_value(spec, value, f"{where}.choice", refuse)
        return Vary(key, kind, tuple(args), per_joint)
    if spec.kind is not float or (spec.is_list and not spec.per_joint):
        raise refuse(where, f"{kind} draws a number; {key} is not a number (use choice: [...])")
    if not isinstance(args, list) or len(args) != 2 or not all(_is_number(a) for a in args):
        names = "[mean, sd]" if kind == "normal" else "[lo, hi]"
        raise refuse(f"{where}.{kind}", f"expected {names}, two numbers, got {args!r}")
    a, b = (float(x) for x in args)
    if kind == "normal":
        if b < 0:
            raise refuse(f"{where}.normal", f"the standard deviation must be >= 0, got {b:g}")
        _check_value(spec, a, f"{where}.normal (the mean)", refuse)
    else:
        if not a <= b:
            raise refuse(f"{where}.{kind}", f"expected lo <= hi, got [{a:g}, {b:g}]")
        if kind == "loguniform" and a <= 0:
            raise refuse(f"{where}.loguniform", f"lo must be > 0 (a log scale), got {a:g}")
        for value in (a, b):
            _check_value(spec, value, f"{where}.{kind}", refuse)
    return Vary(key, kind, (a, b), per_joint, spec.minimum, spec.maximum)


def _preparation(raw: dict[str, Any], refuse) -> dict[str, Any]:
    """``identify`` and ``tune``: what is done to each world before its run, as its user would."""
    from robot_controller.experiments.autotune.chain import TARGETS

    identify, tune = raw.get("identify", False), raw.get("tune")
    if not isinstance(identify, bool):
        raise refuse("identify", f"expected true or false, got {identify!r}")
    if tune is None:
        return {"identify": identify}
    if tune not in TARGETS:
        raise refuse("tune", f"expected one of {', '.join(TARGETS)}, got {tune!r}")
    if not identify:
        raise refuse("tune", "tunes the world identified: give identify: true with it")
    return {"identify": True, "tune": tune}


def _is_number(value: Any) -> bool:
    return not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value)


def _check_value(spec: cfg.ParamSpec, value: Any, where: str, refuse) -> None:
    try:
        spec.validate(value)
    except ConfigError as exc:
        raise refuse(where, str(exc).removeprefix(f"{spec.name}: ")) from None


def _pass_bounds(raw: Any, refuse) -> dict[str, float]:
    if raw is None:
        return {}
    if not isinstance(raw, dict) or not raw:
        raise refuse(
            "pass", "expected a mapping of a figure to its largest passing value, e.g. tracking_rms_rad: 0.005"
        )
    bounds = {}
    for metric, bound in raw.items():
        if metric not in FIGURES:
            hint = difflib.get_close_matches(str(metric), FIGURES, n=1)
            why = "not a run's figure" + (f" (did you mean {hint[0]!r}?)" if hint else f"; figures are {FIGURES}")
            raise refuse(f"pass.{metric}", why)
        if not _is_number(bound) or bound < 0:
            raise refuse(f"pass.{metric}", f"expected the largest passing value, a number >= 0, got {bound!r}")
        bounds[str(metric)] = float(bound)
    return bounds


def run_seed(campaign_seed: int, run_id: int) -> int:
    """Run ``run_id``'s noise seed (the sensor's), a 31-bit integer the parameter schema accepts."""
    return int(np.random.SeedSequence([campaign_seed, run_id]).generate_state(1)[0] >> 1)


def draw(spec: CampaignSpec, run_id: int) -> dict[str, Any]:
    """``{node.parameter: value}`` for run ``run_id``: a number, or a list of one per joint (``per_joint``)."""
    return {v.key: _draw_one(v, spec.seed, run_id, spec.joint_count) for v in spec.vary}


def _draw_one(vary: Vary, campaign_seed: int, run_id: int, joint_count: int) -> Any:
    rng = np.random.default_rng(np.random.SeedSequence([campaign_seed, run_id, zlib.crc32(vary.key.encode())]))
    size = joint_count if vary.per_joint else 1
    if vary.kind == "choice":
        picked = [vary.args[int(i)] for i in rng.integers(len(vary.args), size=size)]
        return picked if vary.per_joint else picked[0]
    a, b = vary.args
    if vary.kind == "uniform":
        values = rng.uniform(a, b, size)
    elif vary.kind == "loguniform":
        values = np.exp(rng.uniform(np.log(a), np.log(b), size))
    else:  # normal, clipped to the parameter's range (a noise σ below 0 is no world)
        values = rng.normal(a, b, size)
        lo = -np.inf if vary.minimum is None else vary.minimum
        hi = np.inf if vary.maximum is None else vary.maximum
        values = np.clip(values, lo, hi)
    floats = [float(x) for x in values]
    return floats if vary.per_joint else floats[0]


def columns(drawn: dict[str, Any]) -> dict[str, Any]:
    """The draws as a row's columns: a per-joint list becomes ``key[0]``, ``key[1]``, …"""
    out: dict[str, Any] = {}
    for key, value in drawn.items():
        if isinstance(value, list):
            out.update({f"{key}[{j}]": v for j, v in enumerate(value)})
        else:
            out[key] = value
    return out


def layer(drawn: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """The draws as a parameter layer ``{node: {parameter: value}}``, to merge over the campaign's stack."""
    out: dict[str, dict[str, Any]] = {}
    for key, value in drawn.items():
        node, _, name = key.partition(".")
        out.setdefault(node, {})[name] = value
    return out
