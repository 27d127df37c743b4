"""One scored run: a launched run's bag read back, scored over the span its clock gives, the host's share of its
misses set apart, judged against its band and summed up. ``run``, ``score DIR``, every experiment, ``faults`` and the
benches score through here, so a run says the same wherever it is scored.

The span by clock: in sim time (``--sim-time``, the paced world) the ticks of the run's ``--duration`` from its first
(the simulator runs on a little past it); on the wall clock, or interrupted, the stops after the run's own span are its
shutdown's, not counted. When the recorder heard each message (latency to the motor, counts, rates) is a figure on
every clock but ``--sim-time``'s, where it differs run to run."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from robot_controller.core import metrics as core_metrics
from robot_controller.scoring import plots, report, summary, verdict
from robot_controller.scoring.bag_reader import Recording
from robot_controller.scoring.camera_figures import camera_figures

if TYPE_CHECKING:
    from robot_controller.runner.plan import CheckedRun
    from robot_controller.runner.supervise import RunResult

SIM_TIME, PACED, WALL = "sim_lockstep", "sim_paced", "wall"  #: ``metrics.json``'s ``clock`` (``--sim-time``, …)


@dataclass
class ScoredRun:
    """What a run scored to: its figures and facts, the host's figures apart, its verdict."""

    recording: Recording
    metrics: dict[str, Any]  #: figures and the run's facts: ``metrics.json`` without the verdict
    verdict: verdict.Verdict
    band_rad: float  #: the tracking band it was judged by
    #: a ``--sim-time`` run's host figures (wall time, CPU, unrecorded messages): ``timing.json``, differing run to run
    timing: dict[str, Any] = field(default_factory=dict)
    facts: dict[str, Any] = field(default_factory=dict)  #: a re-scored run's saved ``metrics.json`` (robot, clock, …)
    effort_limits: list[float] | None = None  #: the controller's ``torque_max`` per joint (N·m, or N), if known

    @property
    def judged(self) -> dict[str, Any]:
        """``metrics.json``: the figures, facts and verdict."""
        return self.metrics | self.verdict.as_metrics() | {"tracking_band_rad": self.band_rad}

    def rows(self, out: Path | None = None) -> list[summary.Row]:
        """``out``: the run's directory, as the user named it."""
        figures = self.facts | self.judged | self.timing
        return summary.run_rows(figures, effort_limits=self.effort_limits, out=None if out is None else str(out))

    def write(self, out: Path, *, command: str) -> None:
        """``metrics.json`` (``timing.json`` with ``--sim-time``), ``tracking.png`` and ``summary.md`` into ``out``."""
        values = self.metrics
        report.write_metrics(out / "metrics.json", self.judged)
        if self.timing:
            report.write_metrics(out / "timing.json", self.timing)
        title = f"{values['robot']}, preset {values['preset']}, seed {values['seed']}"
        plots.plot_tracking(self.recording, out / "tracking.png", title=title, units=values["joint_units"])
        links = ["tracking.png", "bag/", "metrics.json", "params.yaml"]
        (out / "summary.md").write_text(
            summary.markdown(self.verdict.line, self.rows(out), title=f"Run {out.name}", command=command, links=links)
        )


def effort_limits(params: dict[str, Any], joint_count: int) -> list[float] | None:
    """The controller's ``torque_max`` per joint (N·m or N), None if it cannot be read."""
    from robot_controller.core.errors import ConfigError
    from robot_controller.parameters.torque_limits import torque_limit

    try:
        return torque_limit(params["pid_controller"], joint_count).tolist()
    except (ConfigError, KeyError, ValueError):
        return None


def has_ticks(result: RunResult) -> bool:
    """Whether the run's bag holds a controller tick to score."""
    from robot_controller.blocks import spec

    return bool(result.message_counts.get(spec.STATE.topic))


def score_launched(checked: CheckedRun, result: RunResult) -> ScoredRun:
    """What :func:`robot_controller.runner.launcher.launch` ran from ``checked``, scored; ``ValueError`` if its
    recording cannot be (no controller tick, a torn bag)."""
    from robot_controller import robots

    options, params = checked.options, checked.params
    clock = PACED if options.paced else SIM_TIME if options.sim_time else WALL
    recording = report.read_recording(result.bag_dir)
    sim = clock != WALL
    # On the wall clock, or interrupted, the nodes stop one by one after the run: the stops that follow (a
    # controller gone before the drive's timeout) are not the run's.
    judged_s = result.control_seconds if result.interrupted or not sim else None
    values = report.score(
        recording,
        nominal_period_s=recorded_period_s(params, options),
        window_s=options.duration_s if sim else None,
        units=report.arm_units(params["simulator"]["urdf_path"]),
        receipts=clock != SIM_TIME,
        judged_s=judged_s,
    )
    recorded_s = result.control_seconds if result.interrupted or not sim else options.duration_s
    if sim and result.failure is not None and values.get("recorded_duration_s") is not None:
        recorded_s = min(recorded_s, values["recorded_duration_s"])  # ended early: the ticks' own span (seeded)
    robot = robots.arm_name(options.robot, params["simulator"]["urdf_path"])
    values.update(duration_s=round(recorded_s, 3), interrupted=result.interrupted, preset=options.preset, robot=robot)
    values.update(seed=options.seed, mode="single_process" if options.single_process else "multi_process")
    values.update(clock=clock, sensing=options.sensing)
    if options.sensing != "encoders":
        joint_names = report.arm_joint_names(params["simulator"]["urdf_path"])
        values.update(camera_figures(recording.camera_time_s, recording.camera_position_std, joint_names))
    if options.nodes is not None and len(result.local_nodes) < 5:  # a split run: what ran here (the rest elsewhere)
        values["nodes_here"] = ",".join(result.local_nodes)
    # Wall-clock figures of a ``--sim-time`` run differ run to run: kept out of metrics.json.
    host = {"real_time_factor": result.real_time_factor, "wall_duration_s": result.wall_seconds}
    # How many messages the bag misses depends on when the nodes stopped, not on the seed.
    (host if clock == SIM_TIME else values)["unrecorded_messages"] = sum(result.unrecorded.values())
    if clock == SIM_TIME:
        host.update(result.usage)
    else:  # a paced world's freezes and its loop's late efforts, or the wall clock's
        values.update(result.world_clock)
        ticks = recording.state["time_s"]
        period_s = recorded_period_s(params, options)
        missed = core_metrics.missed_ticks_ending_at(result.host_missed_ends_s, ticks, period_s)
        set_host_share_apart(values, missed, core_metrics.periods_ending_within(result.host_watchdog_s, ticks))
        values.update(result.clocks)  # a split run's hosts' clock offset
        values.update(result.robot_timing)  # a robot's own clock
        if options.hardware is not None:
            values["hardware"] = options.hardware
        values["realtime_requested"] = options.realtime
        values.update(result.usage)
    if clock == PACED:
        values.update(host)  # not the same run to run: the host's
    band_rad = options.tracking_band_rad or robots.robot(options.robot).tracking_band_rad
    failure = result.failure if result.exit_code else None
    values["run_failure"] = failure  # apart from a verdict on a run that ran
    judged = verdict.judge(values, band_rad=band_rad, failure=failure)
    limits = effort_limits(params, recording.joint_count)
    timing = host if clock == SIM_TIME else {}
    return ScoredRun(recording, values, judged, band_rad, timing=timing, effort_limits=limits)


def recorded_period_s(params, options) -> float:
    """The period of the controller's recorded ticks: each tick's, or on a robot every ``TELEMETRY_EVERY``-th (its
    1 kHz is the drive's to count)."""
    period_s = 1.0 / params["pid_controller"]["control_rate_hz"]
    if options.hardware is not None:
        from robot_controller.hardware.robot_link import TELEMETRY_EVERY

        period_s *= TELEMETRY_EVERY
    return period_s


def rescore(run_dir: Path) -> ScoredRun:
    """A saved run re-scored from its bag and judged by what its ``metrics.json`` saved (band, clock, duration,
    units, the host's share of its misses, failure; none saved: the whole recording, revolute joints, the default
    band). ``FileNotFoundError``, ``ValueError``: no bag there, or one that cannot be scored."""
    from robot_controller import robots

    recording = report.read_recording(run_dir / "bag")
    saved = _saved(run_dir)
    units = saved.get("joint_units") if len(saved.get("joint_units") or []) == recording.joint_count else None
    clock = saved.get("clock")
    duration_s = saved.get("duration_s") if isinstance(saved.get("duration_s"), (int, float)) else None
    sim = clock in (SIM_TIME, PACED) and duration_s is not None and duration_s > 0
    # As the run judged itself: on the wall clock, or interrupted, its stops after its duration are its shutdown's.
    judged_s = duration_s if clock == WALL or saved.get("interrupted") else None
    window_s = duration_s if sim else None
    values = report.score(recording, window_s=window_s, units=units, receipts=clock != SIM_TIME, judged_s=judged_s)
    set_host_share_apart(values, _count(saved, "missed_cycles_host"), _count(saved, "watchdog_ticks_host"))
    band_rad = saved.get("tracking_band_rad") or robots.robot(robots.DEFAULT_ROBOT).tracking_band_rad
    failure = saved.get("run_failure") if isinstance(saved.get("run_failure"), str) else None
    judged = verdict.judge(saved | values, band_rad=band_rad, failure=failure)
    limits = _saved_effort_limits(run_dir, recording.joint_count)
    return ScoredRun(recording, values, judged, band_rad, facts=saved, effort_limits=limits)


def set_host_share_apart(values: dict[str, Any], missed_cycles: int, watchdog_ticks: int) -> None:
    """Periods the host stretched (the loop waited for a CPU) and watchdog ticks it made (the readings' silence past
    the window was its doing), among those scored: counted apart (``…_host``), not as the loop's own."""
    for key, count in (("missed_cycles", missed_cycles), ("watchdog_ticks", watchdog_ticks)):
        if count:
            values[f"{key}_host"] = count
            values[key] = max(0, values.get(key, 0) - count)


def _saved(run_dir: Path) -> dict[str, Any]:
    """The run's ``metrics.json`` (empty if none, or not one of ours)."""
    try:
        saved = json.loads((run_dir / "metrics.json").read_text())
    except (OSError, ValueError):
        return {}
    return saved if isinstance(saved, dict) else {}


def _count(saved: dict[str, Any], key: str) -> int:
    value = saved.get(key)
    return int(value) if isinstance(value, (int, float)) and value > 0 else 0


def _saved_effort_limits(run_dir: Path, joint_count: int) -> list[float] | None:
    """The controller's ``torque_max`` from the run's ``params.yaml``, if it can be read."""
    from robot_controller import parameters as cfg
    from robot_controller.core.errors import ConfigError

    try:
        return effort_limits(cfg.read_params_file(run_dir / "params.yaml"), joint_count)
    except ConfigError:
        return None
