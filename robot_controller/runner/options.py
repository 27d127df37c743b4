"""A run's options, built once (from the command line or by an experiment) and handed to ``plan`` and ``launcher``."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

from robot_controller import parameters as cfg
from robot_controller.robots import DEFAULT_ROBOT

NODE_ORDER = ("simulator", "motor_node", "sensor_node", "pid_controller", "trajectory_planner")


@dataclass(frozen=True)
class RunOptions:
    """Which stack a run loads and how its graph runs."""

    duration_s: float = math.inf  #: seconds of control recorded (sim seconds with ``sim_time``); inf: until stopped
    preset: str = "default"
    robot: str = DEFAULT_ROBOT
    config: tuple[Path, ...] = ()  #: parameter files over the preset, later over earlier
    seed: int | None = None  #: the sensor's noise seed (None: the stack's)
    sim_time: bool = False  #: deterministic, on the sim's clock, as fast as the graph goes
    paced: bool = False  #: on the sim's clock paced to the wall clock (the paced world), which pauses with the host
    single_process: bool = False  #: all five nodes on one executor
    realtime: bool = False  #: the simulator's pacing thread SCHED_FIFO (``scheduling``)
    respawn: bool = False  #: a node that dies while the loop runs (wall clock) starts again
    view_port: int | None = None  #: serve the live view on this port (and save ``view.rrd``)
    nodes: tuple[str, ...] | None = None  #: start only these (docs/design.md §6 "Across hosts"); None: all five
    peers: tuple[str, ...] = ()  #: the other hosts' IPv4 addresses: discovery by unicast, UDPv4 only
    run_id: str | None = None  #: the run's name, the same on every launcher (its partition)
    wait_s: float = 60.0  #: how long to wait for the whole graph of a split run
    domain_id: int | None = None  #: the graph's ROS_DOMAIN_ID (default: this process's)
    tracking_band_rad: float | None = None  #: the band the run is judged by (None: the robot's)
    hardware: str | None = None  #: a robot in place of the simulated arm (``franka://HOST``): ``nodes.robot_node``
    sensing: str = "encoders"  #: ``encoders``, ``camera`` or ``both`` (``runner.sensing``)

    @classmethod
    def from_args(cls, args: Any) -> RunOptions:
        """The options a verb's parsed arguments hold (each under its field's name); the others' defaults."""
        given = {f.name: getattr(args, f.name) for f in fields(cls) if getattr(args, f.name, None) is not None}
        for name in ("config", "peers"):
            if name in given:
                given[name] = tuple(given[name])
        if not getattr(args, "view", True):
            given.pop("view_port", None)
        return cls(**given)

    @property
    def world_waits(self) -> bool:
        """The nodes step on the simulator's clock, which waits for each command (``sim_time`` or ``paced``);
        ``duration_s`` is world time."""
        return self.sim_time or self.paced

    def params(self) -> cfg.Params:
        """The stack's parameters: the robot's, the preset over them, the config files over that, the seed."""
        params = cfg.load_stack(self.preset, list(self.config), self.robot)
        if self.seed is not None:
            params["sensor_node"]["seed"] = self.seed
        return params


def check_nodes(text: str) -> tuple[str, ...]:
    """``"simulator,motor_node"`` → those names in the graph's order, or ValueError naming the bad one."""
    names = [part.strip() for part in text.split(",")]
    unknown = [n for n in names if n not in NODE_ORDER]
    if unknown or not names:
        raise ValueError(f"unknown node(s) {', '.join(map(repr, unknown))}: choose from {', '.join(NODE_ORDER)}")
    if len(set(names)) != len(names):
        raise ValueError(f"a node is named twice: {text}")
    return tuple(n for n in NODE_ORDER if n in names)
