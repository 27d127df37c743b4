"""Score a run from its recording: read the bag, compute the metrics of
DESIGN.md §5, write ``metrics.json`` and ``tracking.png``. Works on any saved
bag, so a run can be re-scored later (``robot-controller score DIR``)."""
from __future__ import annotations

import bisect
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

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
    typestore = get_typestore(Stores.ROS2_JAZZY)
    state_rows: list[np.ndarray] = []
    true_t: list[float] = []
    true_q: list[np.ndarray] = []
    true_v: list[np.ndarray] = []
    true_e: list[np.ndarray] = []
    receipt: dict[str, list[int]] = {}
    latency: list[float] = []
    receipts: list[np.ndarray] = []
    reading_t: list[float] = []
    reading_q: list[np.ndarray] = []
    planned: list[tuple[float, np.ndarray]] = []
    brakes: list[tuple[float, np.ndarray]] = []
    with Reader(bag_dir) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        wanted = [c for c in reader.connections
                  if c.topic in ("/controller/state", "/sim/joint_states", "/motor/command_latency",
                               "/motor/command_receipts", "/joint_states", "/trajectory", "/sim/brakes")]
        for connection in reader.connections:
            receipt.setdefault(connection.topic, [])
        for connection, timestamp, raw in reader.messages():
            receipt[connection.topic].append(timestamp)
            if connection not in wanted:
                continue
            msg = typestore.deserialize_cdr(raw, connection.msgtype)
            if connection.topic == "/controller/state":
                state_rows.append(np.asarray(msg.data, dtype=float))
            elif connection.topic == "/motor/command_latency":  # bags from before the receipts
                latency.extend(np.asarray(msg.data, dtype=float).tolist())
            elif connection.topic == "/motor/command_receipts":
                receipts.append(np.asarray(msg.data, dtype=float))
            elif connection.topic == "/trajectory":
                planned.append((timestamp * 1e-9, np.asarray(msg.data, dtype=float)))
            elif connection.topic == "/sim/brakes":
                brakes.append((timestamp * 1e-9, np.asarray(msg.data, dtype=float)))
            elif connection.topic == "/joint_states":
                reading_t.append(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9)
                reading_q.append(np.asarray(msg.position, dtype=float))
            else:
                true_t.append(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9)
                true_q.append(np.asarray(msg.position, dtype=float))
                true_v.append(np.asarray(msg.velocity, dtype=float))
                true_e.append(np.asarray(msg.effort, dtype=float))
    if not state_rows or not true_t:
        raise ValueError(f"{bag_dir}: no /controller/state or /sim/joint_states recorded")
    joint_count = state_layout.joint_count_of(len(state_rows[0]))
    state = state_layout.decode(np.vstack(state_rows), joint_count)
    if receipts:
        latency = motor_latency_s(state, np.concatenate(receipts).reshape(-1, 1 + joint_count)).tolist()
    # Our planner's message is [positions, velocities, accelerations, time_s]; the tutorial's [p, v].
    planned = [(data[-1] if len(data) == 3 * joint_count + 1 else t, data[:joint_count]) for t, data in planned
               if len(data) >= joint_count]
    return Recording(state=state, true_time_s=np.asarray(true_t), true_position=np.vstack(true_q),
                     true_velocity=np.vstack(true_v), true_effort=np.vstack(true_e), counts=counts,
                     receipt_s={k: np.asarray(v) * 1e-9 for k, v in receipt.items()},
                     motor_latency_s=np.asarray(latency), reading_stamp_s=np.asarray(reading_t),
                     reading_position=np.vstack(reading_q) if reading_q else np.zeros((0, joint_count)),
                     planned_time_s=np.asarray([t for t, _ in planned]),
                     planned_position=np.vstack([q for _, q in planned]) if planned else np.zeros((0, joint_count)),
                     brakes_time_s=np.asarray([t for t, _ in brakes]),
                     brakes=np.vstack([b for _, b in brakes]) if brakes else np.zeros((0, joint_count)))


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
    active = s["status"] == state_layout.STATUS_CODES["ok"]
    ticks = s["time_s"]
    true_at_tick = metrics.true_position_at(ticks, recording.true_time_s, recording.true_position,
                                            recording.true_velocity)
    out: dict[str, Any] = {}
    raw = recording.raw_reading_at(s["measurement_stamp_s"])
    measured = np.where(np.isfinite(raw), raw, s["measured"])  # readings not recorded: what the law used
    try:
        out.update(metrics.tracking_metrics(ticks[active], s["reference"][active], true_at_tick[active],
                                            measured[active], warmup_s=warmup_s))
    except ValueError:
        pass  # too short to score tracking (timing-only runs): the timing figures still stand
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
