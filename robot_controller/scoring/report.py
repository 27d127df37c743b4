"""Score a run from its recording: read the bag, compute the metrics of
docs/design.md §7, write ``metrics.json`` and ``tracking.png``. Works on any saved
bag, so a run can be re-scored later (``robot-controller score DIR``)."""
from __future__ import annotations

import bisect
import json
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

from robot_controller.scoring import bag_recovery
from robot_controller.core import metrics, state_layout


@dataclass
class Recording:
    """The loop's signals read back from a bag, as arrays (times in s)."""

    state: dict[str, np.ndarray]  #: /controller/state decoded; ``time_s`` is the controller's tick time
    true_time_s: np.ndarray
    true_position: np.ndarray
    true_velocity: np.ndarray
    true_effort: np.ndarray
    counts: dict[str, int] = field(default_factory=dict)
    receipt_s: dict[str, np.ndarray] = field(default_factory=dict)  #: bag receive times per topic
    motor_latency_s: np.ndarray = field(default_factory=lambda: np.zeros(0))  #: stamp → command at the motor
    reading_stamp_s: np.ndarray = field(default_factory=lambda: np.zeros(0))  #: /joint_states stamps
    reading_position: np.ndarray = field(default_factory=lambda: np.zeros((0, 1)))  #: the raw, noisy readings
    #: the planner's samples: their time (its stamp, else when recorded) and positions
    planned_time_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    planned_position: np.ndarray = field(default_factory=lambda: np.zeros((0, 1)))
    planned_velocity: np.ndarray = field(default_factory=lambda: np.zeros((0, 1)))
    #: messages that could not be decoded or did not fit the run's joint count, per topic: skipped
    malformed: dict[str, int] = field(default_factory=dict)
    #: /sim/brakes: when recorded, and 1/0 per joint
    brakes_time_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    brakes: np.ndarray = field(default_factory=lambda: np.zeros((0, 1)))

    def raw_reading_at(self, stamps_s: np.ndarray) -> np.ndarray:
        """The sensor's raw position for each measurement stamp (NaN where not recorded).

        ``/controller/state`` carries what the law acted on, which is the
        Kalman estimate when the filter is on; ``measured_rms_rad`` is defined
        on the noisy reading itself.
        """
        out = np.full((len(stamps_s), self.true_position.shape[1]), np.nan)
        if len(self.reading_stamp_s) == 0:
            return out
        keys = np.round(self.reading_stamp_s * 1e6).astype(np.int64)
        order = np.argsort(keys)
        wanted = np.round(np.asarray(stamps_s) * 1e6).astype(np.int64)
        index = np.clip(np.searchsorted(keys[order], wanted), 0, len(keys) - 1)
        found = keys[order][index] == wanted
        out[found] = self.reading_position[order][index[found]]
        return out

    @property
    def joint_count(self) -> int:
        return self.true_position.shape[1]


def read_recording(bag_dir: Path) -> Recording:
    """Read a run's bag. A message that cannot be decoded, or whose sizes do not
    fit the run (an empty ``JointState``, a short ``/controller/state``: anyone
    on the domain could have published it), is skipped and counted in
    ``malformed``; what is left is scored."""
    bag_dir = Path(bag_dir)
    if bag_recovery.needs_recovery(bag_dir):
        # The recorder was killed: rebuild the bag from its complete chunks first.
        recovered = bag_recovery.recover(bag_dir)
        print(f"{bag_dir}: the recording was not closed (recorder killed); recovered {recovered} messages "
              f"into a complete bag, the torn file kept as {bag_dir.name}.torn", file=sys.stderr)
    typestore = get_typestore(Stores.ROS2_JAZZY)
    decoded: dict[str, list[tuple[int, Any]]] = {topic: [] for topic in WANTED_TOPICS}
    receipt: dict[str, list[int]] = {}
    malformed: dict[str, int] = {}
    with Reader(bag_dir) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        for connection in reader.connections:
            receipt.setdefault(connection.topic, [])
        for connection, timestamp, raw in reader.messages():
            receipt[connection.topic].append(timestamp)
            if connection.topic not in decoded:
                continue
            try:
                decoded[connection.topic].append((timestamp, typestore.deserialize_cdr(raw, connection.msgtype)))
            except Exception:  # noqa: BLE001 - any undecodable bytes: skipped, counted
                malformed[connection.topic] = malformed.get(connection.topic, 0) + 1
    joint_count = _joint_count_of(decoded)

    def keep(topic: str, rows: list[Any], fits: Any) -> list[Any]:
        good = [row for row in rows if fits(row)]
        if len(good) < len(rows):
            malformed[topic] = malformed.get(topic, 0) + len(rows) - len(good)
        return good

    def joint_state_fits(row: tuple[int, Any]) -> bool:
        msg = row[1]
        return (len(msg.position) == joint_count and len(msg.velocity) == joint_count
                and np.all(np.isfinite(msg.position)) and np.all(np.isfinite(msg.velocity)))

    state_width = state_layout.width(joint_count)
    state_rows = [np.asarray(msg.data, dtype=float) for _, msg in
                  keep("/controller/state", decoded["/controller/state"], lambda r: len(r[1].data) == state_width)]
    true = keep("/sim/joint_states", decoded["/sim/joint_states"],
                lambda r: joint_state_fits(r) and len(r[1].effort) == joint_count)
    readings = keep("/joint_states", decoded["/joint_states"], joint_state_fits)
    if not state_rows or not true:
        raise ValueError(f"{bag_dir}: no usable /controller/state or /sim/joint_states recorded")
    state = state_layout.decode(np.vstack(state_rows), joint_count)
    # Our planner's message is [positions, velocities, accelerations, time_s]; the tutorial's [p, v].
    planned = []
    for timestamp, msg in decoded["/trajectory"]:
        data = np.asarray(msg.data, dtype=float)
        if len(data) == 3 * joint_count + 1 and np.all(np.isfinite(data)):
            planned.append((data[-1], data[:joint_count], data[joint_count:2 * joint_count]))
        elif len(data) == 2 * joint_count and np.all(np.isfinite(data)):
            planned.append((timestamp * 1e-9, data[:joint_count], data[joint_count:]))
        else:
            malformed["/trajectory"] = malformed.get("/trajectory", 0) + 1
    brakes = keep("/sim/brakes", [(t, np.asarray(m.data, dtype=float)) for t, m in decoded["/sim/brakes"]],
                  lambda r: r[1].size == joint_count)
    receipts = [np.asarray(m.data, dtype=float) for _, m in decoded["/motor/command_receipts"]]
    receipts = [r for r in receipts if r.size % (1 + joint_count) == 0]
    latency = [v for _, m in decoded["/motor/command_latency"] for v in m.data]  # bags from before the receipts
    if receipts:
        latency = motor_latency_s(state, np.concatenate(receipts).reshape(-1, 1 + joint_count)).tolist()

    def stamp(msg: Any) -> float:
        return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9

    def rows(values: list[np.ndarray]) -> np.ndarray:
        return np.vstack(values) if values else np.zeros((0, joint_count))

    return Recording(
        state=state, true_time_s=np.array([stamp(m) for _, m in true]),
        true_position=rows([np.asarray(m.position, float) for _, m in true]),
        true_velocity=rows([np.asarray(m.velocity, float) for _, m in true]),
        true_effort=rows([np.asarray(m.effort, float) for _, m in true]), counts=counts,
        receipt_s={k: np.asarray(v) * 1e-9 for k, v in receipt.items()},
        motor_latency_s=np.asarray(latency, dtype=float), reading_stamp_s=np.array([stamp(m) for _, m in readings]),
        reading_position=rows([np.asarray(m.position, float) for _, m in readings]),
        planned_time_s=np.array([t for t, _, _ in planned]), planned_position=rows([q for _, q, _ in planned]),
        planned_velocity=rows([v for _, _, v in planned]),
        brakes_time_s=np.array([t * 1e-9 for t, _ in brakes]), brakes=rows([b for _, b in brakes]),
        malformed=malformed)


WANTED_TOPICS = ("/controller/state", "/sim/joint_states", "/motor/command_latency", "/motor/command_receipts",
                 "/joint_states", "/trajectory", "/sim/brakes")


def _joint_count_of(decoded: dict[str, list[tuple[int, Any]]]) -> int:
    """The run's joint count: what most true-state messages carry (a stray one cannot change it)."""
    sizes = [len(msg.position) for _, msg in decoded["/sim/joint_states"] if len(msg.position) > 0]
    if not sizes:
        raise ValueError("no /sim/joint_states with joint positions recorded")
    values, counts = np.unique(sizes, return_counts=True)
    return int(values[np.argmax(counts)])


def motor_latency_s(state: dict[str, np.ndarray], receipts: np.ndarray) -> np.ndarray:
    """Sensor stamp → command at the motor, per command the motor received.

    ``receipts`` rows are ``[receipt_time_s, command…]`` (the motor's); each is
    paired with the controller tick that issued the same command, the latest
    whose reading was taken before the receipt.
    """
    stamps_by_command: dict[tuple[float, ...], list[float]] = {}
    for command, stamp in zip(map(tuple, state["command"].tolist()), state["measurement_stamp_s"].tolist()):
        stamps_by_command.setdefault(command, []).append(stamp)
    out = []
    for row in receipts.tolist():
        stamps = stamps_by_command.get(tuple(row[1:]))
        if not stamps:
            continue  # a command from another publisher, or its tick not recorded
        index = bisect.bisect_right(stamps, row[0]) - 1  # stamps are in tick order
        if index >= 0:
            out.append(row[0] - stamps[index])
    return np.asarray(out)


def score(recording: Recording, *, nominal_period_s: float = 0.01, warmup_s: float = metrics.WARMUP_S,
          window_s: float | None = None) -> dict[str, Any]:
    """The run's metrics: tracking on the TRUE position, rates, latency, message counts.

    ``window_s`` keeps only the first ``window_s`` seconds of control ticks
    and leaves out what depends on when the recorder heard a message: with
    lockstep sim time, the same seed then gives the same figures, exactly.
    """
    s = recording.state
    if window_s is not None:
        keep = s["time_s"] < s["time_s"][0] + window_s - 1e-9
        s = {k: v[keep] for k, v in s.items()}
    ticks = s["time_s"]
    out: dict[str, Any] = {}
    end_s = ticks[0] + window_s if window_s is not None else ticks[-1]
    out.update(tracking_on_sim_timeline(recording, ticks[0] + warmup_s, end_s, nominal_period_s))
    # The sensor's own readings against the reference the law used with them (null if not recorded).
    active = s["status"] == state_layout.STATUS_CODES["ok"]
    raw = recording.raw_reading_at(s["measurement_stamp_s"])
    scored = active & (ticks >= ticks[0] + warmup_s) & np.all(np.isfinite(raw), axis=1)
    out["measured_rms_rad"] = (float(np.sqrt(np.mean((s["reference"][scored] - raw[scored]) ** 2)))
                               if np.any(scored) else float("nan"))
    out["malformed_messages"] = int(sum(recording.malformed.values()))
    out.update(metrics.rate_metrics(ticks, nominal_period_s))
    out["control_ticks"] = int(len(ticks))
    out["watchdog_ticks"] = int(np.count_nonzero(s["status"] == state_layout.STATUS_CODES["watchdog"]))
    # Ticks spent handling a fault (controlled stops, torque off, re-acquiring, e-stop): not
    # scored as tracking, so each is counted.
    for name in ("sensor_lost", "reacquiring", "reference_lost", "stopped"):
        out[f"{name}_ticks"] = int(np.count_nonzero(s["status"] == state_layout.STATUS_CODES[name]))
    out["saturated_ticks"] = int(np.count_nonzero(np.any(s["saturated"] > 0.5, axis=1)))
    out["peak_torque_nm"] = float(np.max(np.abs(s["command"])))
    out["recorded_duration_s"] = float(ticks[-1] - ticks[0])
    ok_ticks = s["status"] != state_layout.STATUS_CODES["no_measurement"]
    out.update(metrics.latency_metrics(s["time_s"][ok_ticks] - s["measurement_stamp_s"][ok_ticks],
                                       prefix="controller_latency"))
    if window_s is not None:
        return out
    out.update(metrics.latency_metrics(recording.motor_latency_s, prefix="latency"))
    for topic, times in recording.receipt_s.items():
        key = topic.strip("/").replace("/", "_")
        out[f"msgs_{key}"] = int(recording.counts.get(topic, len(times)))
        if len(times) > 1 and times[-1] > times[0]:
            out[f"rate_{key}_hz"] = float((len(times) - 1) / (times[-1] - times[0]))
    return out


def tracking_on_sim_timeline(recording: Recording, start_s: float, end_s: float,
                             nominal_period_s: float = 0.01) -> dict[str, Any]:
    """Tracking on the simulator's timeline: every true-state sample from
    ``start_s`` to ``end_s`` against the reference in force at that time.

    The reference in force is the controller's: between two ticks a normal
    period apart, interpolated (it moves with the trajectory); across a longer
    gap (a controller that stalled or was frozen), the last one it issued,
    carried on at its speed for as long as a drive acts on a last command
    (``CARRY_S``, the motor's command timeout), then held. So a stalled
    controller cannot hide: its ticks are missing, the arm's samples are not.
    """
    s = recording.state
    ticks, reference = s["time_s"], s["reference"]
    t, q = recording.true_time_s, recording.true_position
    window = (t >= start_s - 1e-9) & (t <= end_s + 1e-9) & (t >= ticks[0])
    index = np.clip(np.searchsorted(ticks, t, side="right") - 1, 0, len(ticks) - 1)
    following = np.clip(index + 1, 0, len(ticks) - 1)
    span = ticks[following] - ticks[index]
    interpolate = (following > index) & (span <= GAP_PERIODS * nominal_period_s)
    fraction = np.where(interpolate, (t - ticks[index]) / np.where(span > 0, span, 1.0), 0.0)[:, None]
    in_force = reference[index] + np.clip(fraction, 0.0, 1.0) * (reference[following] - reference[index])
    # Across a gap: the last reference, at the speed it had (from the tick before it).
    previous = np.clip(index - 1, 0, len(ticks) - 1)
    step_s = ticks[index] - ticks[previous]
    normal = (index > previous) & (step_s <= GAP_PERIODS * nominal_period_s)
    speed = np.where(normal[:, None], (reference[index] - reference[previous])
                     / np.where(step_s > 0, step_s, 1.0)[:, None], 0.0)
    carried = reference[index] + speed * np.clip(t - ticks[index], 0.0, CARRY_S)[:, None]
    in_force = np.where(interpolate[:, None], in_force, carried)
    # A tick that commands nothing (no reading yet, sensor lost, e-stop: the brake holds) puts no
    # reference in force.
    idle = np.isin(s["status"], [state_layout.STATUS_CODES[name] for name in IDLE_STATUSES])
    window &= ~idle[index]
    if not np.any(window):
        return {"tracking_rms_rad": float("nan"), "tracking_max_rad": float("nan"), "scored_samples": 0}
    error = in_force[window] - q[window]
    return {"tracking_rms_rad": float(np.sqrt(np.mean(error ** 2))), "tracking_max_rad": float(np.max(np.abs(error))),
            "scored_samples": int(np.count_nonzero(window))}


# Ticks further apart than this many control periods: the controller was not running.
GAP_PERIODS = 5
# How long a drive goes on acting on the last command it got (motor command_timeout_s).
CARRY_S = 0.05
# Controller states that command no torque (core.controller.Status.commanding is False).
IDLE_STATUSES = ("no_measurement", "sensor_lost", "stopped")


def json_safe(value: Any) -> Any:
    """NaN (a figure that could not be measured, e.g. a step that never settled) as null: strict JSON."""
    if isinstance(value, float) and not np.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    return value


def write_metrics(path: Path, values: dict[str, Any]) -> None:
    path.write_text(json.dumps(json_safe(values), indent=2, sort_keys=True, allow_nan=False) + "\n")


def plot_tracking(recording: Recording, path: Path, title: str = "") -> None:
    """Reference, true and measured position; tracking error; commanded and applied torque."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    s = recording.state
    t0 = s["time_s"][0]
    t = s["time_s"] - t0
    true_at_tick = metrics.true_position_at(s["time_s"], recording.true_time_s, recording.true_position,
                                            recording.true_velocity)
    fig, axes = plt.subplots(3, 1, figsize=(10, 8), sharex=True, constrained_layout=True)
    for j in range(recording.joint_count):
        tag = f" j{j + 1}" if recording.joint_count > 1 else ""
        axes[0].plot(t, s["reference"][:, j], "k--", lw=1.2, label=f"reference{tag}")
        axes[0].plot(t, true_at_tick[:, j], lw=1.2, label=f"true{tag}")
        axes[0].plot(t, s["measured"][:, j], ".", ms=1.5, alpha=0.5, label=f"measured{tag}")
        axes[1].plot(t, (s["reference"][:, j] - true_at_tick[:, j]) * 1e3, lw=1, label=f"reference − true{tag}")
        axes[1].plot(t, (s["reference"][:, j] - s["measured"][:, j]) * 1e3, lw=0.5, alpha=0.4,
                     label=f"reference − measured{tag}")
        axes[2].plot(t, s["command"][:, j], lw=1, label=f"command{tag}")
        axes[2].plot(recording.true_time_s - t0, recording.true_effort[:, j], lw=0.8, alpha=0.7,
                     label=f"applied{tag}")
    axes[0].set_ylabel("position [rad]")
    axes[1].set_ylabel("error [mrad]")
    axes[2].set_ylabel("torque [N·m]")
    axes[2].set_xlabel("time since first control tick [s]")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
    ax1_lim = np.nanpercentile(np.abs((s["reference"] - s["measured"]) * 1e3), 99.5) * 1.3
    if np.isfinite(ax1_lim) and ax1_lim > 0:
        axes[1].set_ylim(-ax1_lim, ax1_lim)
    axes[2].set_xlim(t[0], t[-1])
    if title:
        fig.suptitle(title)
    fig.savefig(path, dpi=110)
    plt.close(fig)
