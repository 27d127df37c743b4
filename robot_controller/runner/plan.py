"""What a run starts, before anything starts: its parameters checked whole (``check``), then each
process's arguments and environment, the parameter file and the run's DDS profile (``plan``)."""

from __future__ import annotations

import math
import os
import tempfile
from dataclasses import dataclass, replace
from pathlib import Path

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.core.errors import ConfigError
from robot_controller.nodes.simulator import WORLD_STATE_ENV
from robot_controller.parameters import consistency
from robot_controller.parameters.schema import LOCKSTEP_END_MARGIN_S
from robot_controller.ros import partition, scheduling
from robot_controller.ros.publishing import COUNTS_DIR_ENV, RECORDED_ENV
from robot_controller.runner import sensing
from robot_controller.runner.options import NODE_ORDER, RunOptions, check_nodes
from robot_controller.runner.processes import Process
from robot_controller.view import serve as view_serve

#: The node whose launcher records and scores a split run: the recorder hears the loop where the arm is.
RECORDING_NODE = "simulator"

# Fast DDS sends from the publishing thread, not through a sender thread: sim time runs faster so.
FASTDDS_PUBLICATION_MODE = ("RMW_FASTRTPS_PUBLICATION_MODE", "SYNCHRONOUS")


@dataclass
class RunPlan:
    options: RunOptions
    out_dir: Path
    bag_dir: Path
    counts_dir: Path  #: a scratch folder for the nodes' publish counts and the arm's kept state
    recorder: Process | None  #: None on a launcher of part of the graph without the simulator
    nodes: list[Process]
    notes: list[str]  #: what the launcher should say before starting
    viewer: Process | None  #: the live view (``view_port``): an observer, like the recorder
    view_url: str | None  #: where the live view is served
    watcher: Process | None  #: ``graph_watch``, when the other nodes are another launcher's
    sim_end_s: float | None  #: sim time: the simulator publishes no tick after this sim time

    @property
    def remote_nodes(self) -> tuple[str, ...]:
        """The nodes of the graph another launcher starts."""
        return tuple(n for n in NODE_ORDER if n not in self.options.nodes)

    @property
    def records(self) -> bool:
        return self.recorder is not None


def child_env(single_process: bool) -> dict[str, str]:
    """This process's environment with the settings every child needs (never changes ``os.environ``)."""
    env = dict(os.environ)
    env.setdefault("PYTHONUNBUFFERED", "1")
    env.setdefault("RCUTILS_LOGGING_BUFFERED_STREAM", "0")
    env.setdefault("RCUTILS_COLORIZED_OUTPUT", "0")
    # The prefix already names the process; in one process the node name is needed.
    console_format = "[{severity}] [{name}] {message}" if single_process else "[{severity}] {message}"
    env.setdefault("RCUTILS_CONSOLE_OUTPUT_FORMAT", console_format)
    env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    env.setdefault(*FASTDDS_PUBLICATION_MODE)
    env.setdefault(partition.PROFILES_ENV, str(resources.fastdds_profiles()))  # quick discovery
    env.pop(scheduling.PACING_RT_ENV, None)
    return env


def world_waits_params(params: cfg.Params) -> cfg.Params:
    """The same parameters on the sim's clock, where the world waits: the nodes step on messages instead of timers
    (none uses ROS sim time, which costs a clock callback every tick)."""
    out = cfg.merge(params, {})
    for node in cfg.NODES:
        out[node]["use_sim_time"] = False
    for node in (
        "simulator",
        "pid_controller",
        "trajectory_planner",
        "motor_node",
        "sensor_node",
        *sensing.CAMERA_NODES,
    ):
        out[node][cfg.WORLD_WAITS] = True
    return out


#: rad/s² of the blend from where a robot stands onto the trajectory: a blend of 1 rad peaks at 0.8 rad/s, well
#: inside the Panda's 2.2-2.6 rad/s (the simulated arm's 20 would ask 3.5 rad/s of it)
HARDWARE_REACQUIRE_ACCELERATION = 2.0
#: rad/s² of a robot's controlled stops (the run's end, an e-stop): a torque within the rate limit follows it (0.4 kg·m²
#: of a Panda's elbow takes 1.6 N·m of it, 6 ms at 250 N·m/s); the simulated arm's 20 rang the elbow up at its end
HARDWARE_STOP_DECELERATION = 4.0
#: of each joint's URDF speed limit a robot's trajectory may reach: inside its guard's 85 %
HARDWARE_VELOCITY_SHARE = 0.8
#: the arm model a franka:// robot runs with
FRANKA_ROBOT = "panda"
#: Hz: a robot's own clock (the FCI's 1 kHz) steps its controller
HARDWARE_RATE_HZ = 1000.0


def on_hardware(params: cfg.Params, options: RunOptions) -> tuple[RunOptions, cfg.Params]:
    """A run on a robot: its own clock (the wall clock's), every node here, the controller at the robot's rate, the
    start's blend and the stops gentle, the trajectory within 80 % of each joint's speed limit. ``ConfigError`` for
    what a robot cannot do."""
    from robot_controller.hardware.franka_arm import parse_hardware

    try:
        parse_hardware(options.hardware)
    except ValueError as exc:
        raise ConfigError(str(exc)) from None
    refused = {
        "--sim-time": options.sim_time,
        "--single-process": options.single_process,
        "--respawn": options.respawn,
        "--nodes": options.nodes not in (None, NODE_ORDER),
        "--peers": bool(options.peers),
        "--realtime": options.realtime,
    }
    if said := [flag for flag, given in refused.items() if given]:
        raise ConfigError(f"--hardware: {', '.join(said)} needs the simulator (a robot keeps its own clock)")
    if options.robot != FRANKA_ROBOT:
        raise ConfigError(f"--hardware {options.hardware}: a Franka arm is --robot {FRANKA_ROBOT}, not {options.robot}")
    if params["trajectory_planner"]["feasibility"] == "ignore":
        raise ConfigError("--hardware: feasibility ignore would send a robot past its limits: scale or refuse")
    standing = robot_standing(options.hardware)
    ctrl = params["pid_controller"]
    acceleration = min(float(ctrl["reacquire_acceleration"]), HARDWARE_REACQUIRE_ACCELERATION)
    deceleration = min(float(ctrl["stop_deceleration"]), HARDWARE_STOP_DECELERATION)
    # The robot is the world, the sensor and the drive: its state comes at its own rate, each state a tick.
    rate = HARDWARE_RATE_HZ
    params = cfg.merge(
        params,
        {
            "pid_controller": {
                "control_rate_hz": rate,
                "reacquire_acceleration": acceleration,
                "stop_deceleration": deceleration,
            },
            "simulator": {"control_rate_hz": rate, "publish_rate_hz": rate},
            "sensor_node": {"rate_hz": rate},
            "trajectory_planner": {
                "velocity_share": min(params["trajectory_planner"]["velocity_share"], HARDWARE_VELOCITY_SHARE),
                "start_position": [float(q) for q in standing],
                "stop_deceleration": min(params["trajectory_planner"]["stop_deceleration"], deceleration),
                "velocity_envelope": "fr3",
            },
        },
    )
    return replace(options, paced=False), params


def robot_standing(url: str) -> list[float]:
    """Where the robot at ``url`` stands (its motion starts there), after recovering it, in one line, from a reflex
    a last run left (its drive killed, a fault). ``ConfigError``: it cannot be reached."""
    from robot_controller.hardware.franka_arm import FrankaArm, RobotFault, parse_hardware
    from robot_controller.runner.processes import say

    try:
        arm = FrankaArm(parse_hardware(url))
        try:
            arm.recover_if_needed(say)
            return [float(q) for q in arm.position()]
        finally:
            arm.close()
    except RobotFault as fault:
        raise ConfigError(f"--hardware {url}: {fault.describe()}") from None


@dataclass(frozen=True)
class CheckedRun:
    """A run's parameters as its nodes get them, checked whole for its options (made by :func:`check`)."""

    params: cfg.Params
    options: RunOptions


def check(params: cfg.Params, options: RunOptions) -> CheckedRun:
    """The parameters the nodes get, checked whole with the options before anything is written or started.

    :raises ConfigError: a parameter, or ``view_port`` cannot be served on; part of the graph
        without a run id, or in one process; a run id or peers with a profile of the user's
    """
    local = NODE_ORDER if options.nodes is None else check_nodes(",".join(options.nodes))
    split = local != NODE_ORDER
    if split and options.run_id is None:
        raise ConfigError("--nodes: a launcher of part of the graph needs --run-id NAME, the same as the other side's")
    if split and options.single_process:
        raise ConfigError("--single-process runs all five nodes in one process: it cannot take --nodes")
    if (options.run_id is not None or options.peers) and partition.PROFILES_ENV in os.environ:
        raise ConfigError(
            f"{partition.PROFILES_ENV} is set: --run-id and --peers need the run's own Fast DDS profile; unset it"
        )
    if options.run_id is not None:
        try:
            partition.check_run_id(options.run_id)
        except ValueError as exc:
            raise ConfigError(f"--run-id: {exc}") from None
    if options.hardware is not None:
        options, params = on_hardware(params, options)
    params = consistency.with_controller_model(params)
    if options.sensing != "encoders":
        refused = {"--hardware": options.hardware, "--single-process": options.single_process, "--nodes": split}
        if said := [flag for flag, given in refused.items() if given]:
            raise ConfigError(f"--sensing {options.sensing}: not with {', '.join(said)} (its camera is simulated)")
        params = sensing.with_sensing(params, options.sensing, sim_time=options.sim_time)
    if options.paced and (split or options.peers or options.respawn):
        # Across hosts the drive keeps its host's clock, as on hardware; a respawned simulator would restart time.
        options = replace(options, paced=False)
    if options.world_waits:
        params = world_waits_params(params)
        if options.paced:
            params["simulator"]["real_time_factor"] = 1.0
        if math.isfinite(options.duration_s):
            # The simulator stops a little past the end: the recorder takes every message before the nodes stop.
            params["simulator"]["lockstep_end_s"] = options.duration_s + LOCKSTEP_END_MARGIN_S
    consistency.check_stack(params)
    if options.view_port is not None:
        view_serve.check_port(options.view_port)
    return CheckedRun(params, replace(options, nodes=local))


def plan(run: CheckedRun, out_dir: Path) -> RunPlan:
    """Write what the processes read (``params.yaml``, ``fastdds.xml``) into ``out_dir`` and decide how each starts.

    :raises FileExistsError: ``out_dir`` already holds a recording
    """
    params, options = run.params, run.options
    local = options.nodes
    bag_dir = out_dir / "bag"
    if bag_dir.exists():
        raise FileExistsError(f"{bag_dir} exists: choose another --out")
    out_dir.mkdir(parents=True, exist_ok=True)
    params_file = cfg.write_params_file(params, out_dir / "params.yaml")
    counts_dir = Path(tempfile.mkdtemp(prefix="robot-controller-counts-"))
    notes = []
    env = child_env(options.single_process)
    # Recorded on both sides of a split run: every node's gates wait for the recorder, wherever it runs.
    env.update({RECORDED_ENV: "1", COUNTS_DIR_ENV: str(counts_dir)})
    if options.respawn:
        env[WORLD_STATE_ENV] = str(counts_dir / "world_state.bin")
    if options.domain_id is not None:
        env["ROS_DOMAIN_ID"] = str(options.domain_id)
    if partition.PROFILES_ENV in os.environ:
        notes.append(
            f"{partition.PROFILES_ENV} is set: the run uses that Fast DDS profile and is not isolated "
            "from other publishers on its domain"
        )
    else:  # the run's loop topics in a partition of its own (see ros.partition)
        name = partition.run_partition(options.run_id) if options.run_id is not None else partition.new_partition()
        profile = partition.write_run_profile(out_dir / "fastdds.xml", name, peers=list(options.peers))
        env[partition.PROFILES_ENV] = str(profile)
        env[partition.PARTITION_ENV] = name
        if options.peers:  # the profile alone says how discovery goes (rmw_fastrtps's LOCALHOST would add shm)
            env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = partition.PEERS_DISCOVERY_RANGE
            env[partition.LOOP_QOS_ENV] = "best_effort"  # the loop's readers across a link that loses packets
    node_env = dict(env)
    if options.realtime:
        node_env[scheduling.PACING_RT_ENV] = str(scheduling.PACING_RT_PRIORITY)
    node_args = ["--ros-args", "--params-file", str(params_file)]
    if options.hardware is not None:  # the robot in place of the simulator, the motor, the sensor, the controller
        planner = "trajectory_planner"
        processes = [
            Process("robot", "robot_node", [options.hardware, *node_args], node_env),
            Process(planner, planner, node_args, node_env),
        ]
    elif options.single_process:
        processes = [Process("stack", "all_in_one", node_args, node_env)]
    else:
        started = (*local, *sensing.EXTRA_NODES[options.sensing])
        processes = [Process(name, name, node_args, node_env) for name in started]
    recorder = None
    if RECORDING_NODE in local:
        recorder = Process("recorder", "recorder", [str(bag_dir)] + (["--sim-time"] * options.world_waits), env)
    # The recording launcher's watch measures the other launchers' clocks (wall clock only); theirs answer.
    ask = ["--ask", repr(params["motor_node"]["max_command_age_s"] / 2)] if recorder and not options.world_waits else []
    watch_args = ["--here", ",".join(local), *ask]
    watcher = Process("graph_watch", "graph_watch", watch_args, dict(env)) if local != NODE_ORDER else None
    viewer = view_url = None
    if options.view_port is not None:
        viewer_args = ["--rrd", str(out_dir / "view.rrd"), "--port", str(options.view_port)]
        viewer_args += ["--urdf", str(params["simulator"]["urdf_path"])]
        viewer_args += ["--control-rate", repr(float(params["pid_controller"]["control_rate_hz"]))]
        viewer = Process("viewer", "viewer", viewer_args, dict(env))
        view_url = view_serve.page_url(options.view_port)
    end_s = params["simulator"].get("lockstep_end_s", 0.0) if options.world_waits else 0.0
    return RunPlan(
        options, out_dir, bag_dir, counts_dir, recorder, processes, notes, viewer, view_url, watcher, end_s or None
    )
