"""What a run starts, before anything starts: the processes (the recorder and
the five nodes, or all five in one, and with ``view_port`` the live viewer),
each one's arguments and environment,
the parameter file and the run's DDS profile, all written into the run's
output directory. ``launcher`` then supervises what this plans.

Part of the graph (``nodes``, docs/design.md §6 "Across hosts"): only those
nodes, and a ``graph_watch`` observer that tells the launcher when the other
side's nodes are there and when they leave; the recorder runs only beside the
simulator. ``run_id`` names the partition, so launchers that share it meet;
``peers`` makes the profile UDPv4 only with those addresses as initial peers."""

from __future__ import annotations

import copy
import os
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.core.errors import ConfigError
from robot_controller.nodes.world_state import WORLD_STATE_ENV
from robot_controller.parameters import consistency
from robot_controller.parameters.builders import ARM_MODEL_KEYS
from robot_controller.ros import partition, scheduling
from robot_controller.ros.publishing import COUNTS_DIR_ENV, RECORDED_ENV
from robot_controller.view import serve as view_serve

NODE_ORDER = ("simulator", "motor_node", "sensor_node", "pid_controller", "trajectory_planner")
#: The node whose launcher records and scores a split run: the recorder hears the loop where the arm is.
RECORDING_NODE = "simulator"

# Fast DDS sends from the publishing thread instead of handing each sample to
# a sender thread: when it was introduced, the lockstep ran 1.6× faster with it.
FASTDDS_PUBLICATION_MODE = ("RMW_FASTRTPS_PUBLICATION_MODE", "SYNCHRONOUS")


@dataclass(frozen=True)
class Process:
    name: str  #: as the output prefix and in the usage figures
    module: str  #: ``robot_controller.nodes.<module>``
    args: list[str]
    env: dict[str, str]


@dataclass
class RunPlan:
    out_dir: Path
    bag_dir: Path
    counts_dir: Path  #: a scratch folder for the nodes' publish counts and the arm's kept state
    recorder: Process | None  #: None on a launcher of part of the graph without the simulator
    nodes: list[Process]
    sim_time: bool
    notes: list[str] = field(default_factory=list)  #: what the launcher should say before starting
    viewer: Process | None = None  #: the live view (``view_port``): an observer, like the recorder
    view_url: str | None = None  #: where the live view is served
    local_nodes: tuple[str, ...] = NODE_ORDER  #: the nodes this launcher starts
    watcher: Process | None = None  #: ``graph_watch``, when the other nodes are another launcher's
    lockstep_end_s: float | None = None  #: lockstep: the simulator publishes no tick after this sim time

    @property
    def remote_nodes(self) -> tuple[str, ...]:
        """The nodes of the graph another launcher starts."""
        return tuple(n for n in NODE_ORDER if n not in self.local_nodes)

    @property
    def records(self) -> bool:
        return self.recorder is not None


def check_nodes(text: str) -> tuple[str, ...]:
    """``"simulator,motor_node"`` → those names in the graph's order, or ValueError naming the bad one."""
    names = [part.strip() for part in text.split(",")]
    unknown = [n for n in names if n not in NODE_ORDER]
    if unknown or not names:
        raise ValueError(f"unknown node(s) {', '.join(map(repr, unknown))}: choose from {', '.join(NODE_ORDER)}")
    if len(set(names)) != len(names):
        raise ValueError(f"a node is named twice: {text}")
    return tuple(n for n in NODE_ORDER if n in names)


def child_env(single_process: bool) -> dict[str, str]:
    """This process's environment with the settings every child needs (never changes ``os.environ``)."""
    env = dict(os.environ)
    env.setdefault("PYTHONUNBUFFERED", "1")
    env.setdefault("RCUTILS_LOGGING_BUFFERED_STREAM", "0")
    env.setdefault("RCUTILS_COLORIZED_OUTPUT", "0")
    # The prefix already names the process; in one process the node name is needed.
    env.setdefault(
        "RCUTILS_CONSOLE_OUTPUT_FORMAT",
        "[{severity}] [{name}] {message}" if single_process else "[{severity}] {message}",
    )
    env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    env.setdefault(*FASTDDS_PUBLICATION_MODE)
    env.setdefault(partition.PROFILES_ENV, str(resources.fastdds_profiles()))  # quick discovery
    env.pop(scheduling.PACING_RT_ENV, None)
    return env


def lockstep_params(params: cfg.Params) -> cfg.Params:
    """The same parameters in sim-time lockstep: the simulator owns /clock and
    the simulator, controller, planner and motor step on messages instead of timers."""
    out = cfg.merge(params, {})
    # No node needs ROS sim time: the sensor steps on the stamps of what it receives, the
    # controller and planner on /clock messages they read themselves, the motor on each
    # command's tick stamp. A node on sim time pays a /clock delivery and callback every tick.
    for node in cfg.NODES:
        out[node]["use_sim_time"] = False
    for node in ("simulator", "pid_controller", "trajectory_planner", "motor_node"):
        out[node]["lockstep"] = True
    return out


def with_controller_model(params: cfg.Params) -> cfg.Params:
    """The same parameters with the controller's arm model given to the planner
    too: each ``model_*`` the planner leaves empty takes pid_controller's value
    (e.g. from an ``identify`` overlay, which sets only the controller's), so that
    the planner checks its trajectory against the arm the controller models, as
    ``consistency.trajectory_plan`` and the in-process loop do. One the planner
    sets must be the controller's: ``consistency.check_stack`` refuses others."""
    out = cfg.merge(params, {})
    planner, ctrl = out["trajectory_planner"], out["pid_controller"]
    for key in ARM_MODEL_KEYS:
        if planner.get(key) is None or np.size(planner[key]) == 0:
            planner[key] = copy.deepcopy(ctrl[key])  # not the same list: YAML would write an alias, which rcl refuses
    return out


def plan(
    params: cfg.Params,
    *,
    out_dir: Path,
    single_process: bool = False,
    realtime: bool = False,
    sim_time: bool = False,
    domain_id: int | None = None,
    respawn: bool = False,
    view_port: int | None = None,
    nodes: Sequence[str] | None = None,
    peers: Sequence[str] | None = None,
    run_id: str | None = None,
) -> RunPlan:
    """Check the whole configuration, then write what the processes read
    (``params.yaml``, ``fastdds.xml``) and decide how each starts.
    ``view_port``: also start the live viewer, serving at
    ``http://127.0.0.1:<view_port>`` and saving ``out_dir/view.rrd``.
    ``nodes``: start only these (default all five); ``run_id``: the partition is this
    name's (:func:`partition.run_partition`), so another launcher naming it joins the run;
    ``peers``: the other hosts' IPv4 addresses, and UDPv4 only (``partition.write_run_profile``).

    :raises ConfigError: before anything is written (also: ``view_port`` cannot be served on;
        part of the graph without a run id, or in one process; a run id or peers with a
        profile of the user's)
    :raises FileExistsError: ``out_dir`` already holds a recording
    """
    local = NODE_ORDER if nodes is None else check_nodes(",".join(nodes))
    split = local != NODE_ORDER
    if split and run_id is None:
        raise ConfigError("--nodes: a launcher of part of the graph needs --run-id NAME, the same as the other side's")
    if split and single_process:
        raise ConfigError("--single-process runs all five nodes in one process: it cannot take --nodes")
    if (run_id is not None or peers) and partition.PROFILES_ENV in os.environ:
        raise ConfigError(
            f"{partition.PROFILES_ENV} is set: --run-id and --peers need the run's own Fast DDS profile; unset it"
        )
    if run_id is not None:
        try:
            partition.check_run_id(run_id)
        except ValueError as exc:
            raise ConfigError(f"--run-id: {exc}") from None
    params = with_controller_model(params)
    if sim_time:
        params = lockstep_params(params)
    consistency.check_stack(params)  # before anything is written or started
    if view_port is not None:
        view_serve.check_port(view_port)
    bag_dir = out_dir / "bag"
    if bag_dir.exists():
        raise FileExistsError(f"{bag_dir} exists: choose another --out")
    out_dir.mkdir(parents=True, exist_ok=True)
    params_file = cfg.write_params_file(params, out_dir / "params.yaml")
    counts_dir = Path(tempfile.mkdtemp(prefix="robot-controller-counts-"))
    notes = []
    env = child_env(single_process)
    # Recorded on both sides of a split run: every node's gates wait for the recorder, wherever it runs.
    env.update({RECORDED_ENV: "1", COUNTS_DIR_ENV: str(counts_dir)})
    if respawn:
        env[WORLD_STATE_ENV] = str(counts_dir / "world_state.bin")
    if domain_id is not None:
        env["ROS_DOMAIN_ID"] = str(domain_id)
    if partition.PROFILES_ENV in os.environ:
        notes.append(
            f"{partition.PROFILES_ENV} is set: the run uses that Fast DDS profile and is not isolated "
            "from other publishers on its domain"
        )
    else:  # the run's loop topics in a partition of its own (see ros.partition)
        name = partition.run_partition(run_id) if run_id is not None else partition.new_partition()
        profile = partition.write_run_profile(out_dir / "fastdds.xml", name, peers=list(peers or ()))
        env[partition.PROFILES_ENV] = str(profile)
        env[partition.PARTITION_ENV] = name
        if peers:  # the profile alone says how discovery goes (rmw_fastrtps's LOCALHOST would add shared memory)
            env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = partition.PEERS_DISCOVERY_RANGE
            env[partition.LOOP_QOS_ENV] = "best_effort"  # the loop's readers across a link that loses packets
    node_env = dict(env)
    if realtime:
        node_env[scheduling.PACING_RT_ENV] = str(scheduling.PACING_RT_PRIORITY)
    node_args = ["--ros-args", "--params-file", str(params_file)]
    processes = (
        [Process("stack", "all_in_one", node_args, node_env)]
        if single_process
        else [Process(name, name, node_args, node_env) for name in local]
    )
    recorder = (
        Process("recorder", "recorder", [str(bag_dir)] + (["--sim-time"] if sim_time else []), env)
        if RECORDING_NODE in local
        else None
    )
    watcher = Process("graph_watch", "graph_watch", [], dict(env)) if split else None
    viewer = view_url = None
    if view_port is not None:
        viewer = Process(
            "viewer",
            "viewer",
            [
                "--rrd",
                str(out_dir / "view.rrd"),
                "--port",
                str(view_port),
                "--urdf",
                str(params["simulator"]["urdf_path"]),
                "--control-rate",
                repr(float(params["pid_controller"]["control_rate_hz"])),
            ],
            dict(env),
        )
        view_url = view_serve.page_url(view_port)
    end_s = params["simulator"].get("lockstep_end_s", 0.0) if sim_time else 0.0
    return RunPlan(
        out_dir,
        bag_dir,
        counts_dir,
        recorder,
        processes,
        sim_time,
        notes,
        viewer,
        view_url,
        local,
        watcher,
        lockstep_end_s=end_s or None,
    )
