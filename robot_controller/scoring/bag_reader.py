"""A run's bag read back as arrays (``Recording``): every topic the scoring needs, decoded; messages that do not fit the
run (malformed, another joint count) skipped and counted.

A torn bag (its recorder killed) is rebuilt first, as ``ros2 bag reindex`` does for an MCAP without summary, footer or
``metadata.yaml``: the records (opcode, length, content) scanned up to the first incomplete one (the recorder closes a
chunk every second) and a new bag written from the messages found (the torn file kept as ``bag.torn``)."""

from __future__ import annotations

import bisect
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

from robot_controller.blocks import spec
from robot_controller.blocks.values import POSITION_STD_PREFIX, brake_reasons, labelled_position_std
from robot_controller.core import metrics
from robot_controller.core.controller import state_layout
from robot_controller.scoring.bag_recovery import needs_recovery, recover

STATE, TRUE_STATE, READING = spec.STATE.topic, spec.TRUE_STATE.topic, spec.READING.topic
REFERENCE, BRAKES, DISTURBANCE_APPLIED = spec.REFERENCE.topic, spec.BRAKES.topic, spec.DISTURBANCE_APPLIED.topic


@dataclass
class Recording:
    """The loop's signals read back from a bag, as arrays (times in s)."""

    state: dict[str, np.ndarray]  #: the controller's state decoded; ``time_s`` is the controller's tick time
    true_time_s: np.ndarray
    true_position: np.ndarray
    true_velocity: np.ndarray
    true_effort: np.ndarray
    counts: dict[str, int] = field(default_factory=dict)
    receipt_s: dict[str, np.ndarray] = field(default_factory=dict)  #: bag receive times per topic
    motor_latency_s: np.ndarray = field(default_factory=lambda: np.zeros(0))  #: stamp → command at the motor
    reading_stamp_s: np.ndarray = field(default_factory=lambda: np.zeros(0))  #: the sensor's readings' stamps
    reading_position: np.ndarray = field(default_factory=lambda: np.zeros((0, 1)))  #: the raw, noisy readings
    camera_time_s: np.ndarray = field(default_factory=lambda: np.zeros(0))  #: a camera's frames' exposures, s
    #: each camera frame's σ per joint (``inf``: no marker seen constrains it); no rows: no camera
    camera_position_std: np.ndarray = field(default_factory=lambda: np.zeros((0, 1)))
    #: the planner's samples: their time (its stamp, else when recorded) and positions
    planned_time_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    planned_position: np.ndarray = field(default_factory=lambda: np.zeros((0, 1)))
    planned_velocity: np.ndarray = field(default_factory=lambda: np.zeros((0, 1)))
    #: messages that could not be decoded or did not fit the run's joint count, per topic: skipped
    malformed: dict[str, int] = field(default_factory=dict)
    #: the brakes' state: when recorded, and 1/0 per joint
    brakes_time_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    brakes: np.ndarray = field(default_factory=lambda: np.zeros((0, 1)))
    #: why each brakes message says they hold (its label's reasons: ``estop``, ``drive_timeout``…; empty if unsaid)
    brakes_reasons: list[frozenset[str]] = field(default_factory=list)
    #: the disturbance applied: the external torque on each joint (N·m) at each time, one zero row after
    disturbance_time_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    disturbance: np.ndarray = field(default_factory=lambda: np.zeros((0, 1)))
    #: the joints' names as the true state gives them, in the order of every array's columns
    recorded_joint_names: list[str] = field(default_factory=list)
    #: the extra blocks on the controller's state by name (a law of one's own's ``state_terms``, N·m per joint; the
    #: inertia adaptation's ``adapted_armature_kgm2``): one row per row of ``state`` (NaN where a message did not
    #: carry the block); empty for a built-in law without the adaptation
    law_terms: dict[str, np.ndarray] = field(default_factory=dict)
    #: the motor's command receipts, rows ``[receipt_time_s, command…]``, and the controller's diagnostics
    #: ``(stamp_s, jitter_p99_ms)``: what the view draws beside the scored signals
    receipts: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    diagnostics: list[tuple[float, float]] = field(default_factory=list)

    def true_at_ticks(self) -> np.ndarray:
        return metrics.true_position_at(self.state["time_s"], self.true_time_s, self.true_position, self.true_velocity)

    def raw_reading_at(self, stamps_s: np.ndarray) -> np.ndarray:
        """The sensor's raw (noisy) position for each measurement stamp, NaN where not recorded."""
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

    @property
    def joint_names(self) -> list[str]:
        """In column order (``joint1``, ``joint2``… if the bag has none that fit)."""
        if len(self.recorded_joint_names) == self.joint_count:
            return list(self.recorded_joint_names)
        return [f"joint{k + 1}" for k in range(self.joint_count)]


def stamp_of(msg: Any) -> float:
    return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9


def read_recording(bag_dir: Path) -> Recording:
    """A message that cannot be decoded, or whose sizes do not fit the run (anyone on the domain could have
    published it), is skipped and counted in ``malformed``."""
    bag_dir = Path(bag_dir)
    if needs_recovery(bag_dir):
        # The recorder was killed: rebuild the bag from its complete chunks first.
        recovered = recover(bag_dir)
        note = f"the recording was not closed (recorder killed); recovered {recovered} messages into a complete bag"
        print(f"{bag_dir}: {note}, the torn file kept as {bag_dir.name}.torn", file=sys.stderr)
    typestore = get_typestore(Stores.ROS2_JAZZY)
    decoded: dict[str, list[tuple[int, Any]]] = {topic: [] for topic in WANTED_TOPICS}
    malformed: dict[str, int] = {}
    with Reader(bag_dir) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        receipt: dict[str, list[int]] = {c.topic: [] for c in reader.connections}
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
        return (
            len(msg.position) == joint_count
            and len(msg.velocity) == joint_count
            and np.all(np.isfinite(msg.position))
            and np.all(np.isfinite(msg.velocity))
        )

    state_width = state_layout.width(joint_count)
    states = keep(STATE, decoded[STATE], lambda r: state_layout.fits(len(r[1].data), joint_count))
    state_msgs = [msg for _, msg in states]
    state_rows = [np.asarray(msg.data[:state_width], dtype=float) for msg in state_msgs]
    law_terms = _law_terms(state_msgs, joint_count)
    true = keep(
        TRUE_STATE,
        decoded[TRUE_STATE],
        lambda r: joint_state_fits(r) and len(r[1].effort) == joint_count,
    )

    def reading_fits(row: tuple[int, Any]) -> bool:  # a camera's says each position's σ and no velocity
        msg = row[1]
        said = msg.header.frame_id.startswith(POSITION_STD_PREFIX) and len(msg.velocity) == 0
        return joint_state_fits(row) or (
            said and len(msg.position) == joint_count and np.all(np.isfinite(msg.position))
        )

    readings = keep(READING, decoded[READING], reading_fits)
    # One camera reading per frame (where the world waits the last is repeated at ticks between frames: skipped).
    seen_stamps: set[float] = set()
    camera_std = []
    for _, msg in [*readings, *decoded[spec.CAMERA_READING.topic]]:  # the camera's, in the loop or beside it
        sigmas = labelled_position_std(msg.header.frame_id)
        if sigmas is not None and sigmas.size == joint_count and stamp_of(msg) not in seen_stamps:
            seen_stamps.add(stamp_of(msg))
            camera_std.append((stamp_of(msg), sigmas))
    if not state_rows or not true:
        raise ValueError(f"{bag_dir}: no usable {STATE} or {TRUE_STATE} recorded")
    state = state_layout.decode(np.vstack(state_rows), joint_count)
    # Our planner's message is [positions, velocities, accelerations, time_s]; the tutorial's [p, v].
    planned = []
    for timestamp, msg in decoded[REFERENCE]:
        data = np.asarray(msg.data, dtype=float)
        if len(data) == 3 * joint_count + 1 and np.all(np.isfinite(data)):
            planned.append((data[-1], data[:joint_count], data[joint_count : 2 * joint_count]))
        elif len(data) == 2 * joint_count and np.all(np.isfinite(data)):
            planned.append((timestamp * 1e-9, data[:joint_count], data[joint_count:]))
        else:
            malformed[REFERENCE] = malformed.get(REFERENCE, 0) + 1
    brakes = keep(
        BRAKES,
        [(t, np.asarray(m.data, dtype=float), _brake_reasons(m)) for t, m in decoded[BRAKES]],
        lambda r: r[1].size == joint_count,
    )
    # [torque_nm…, time_s] (the simulator's); one torque per joint without the time: when recorded.
    disturbance = []
    for timestamp, msg in decoded[DISTURBANCE_APPLIED]:
        data = np.asarray(msg.data, dtype=float)
        if data.size == joint_count + 1 and np.all(np.isfinite(data)):
            disturbance.append((float(data[-1]), data[:-1]))
        elif data.size == joint_count and np.all(np.isfinite(data)):
            disturbance.append((timestamp * 1e-9, data))
        else:
            malformed[DISTURBANCE_APPLIED] = malformed.get(DISTURBANCE_APPLIED, 0) + 1
    receipts = [np.asarray(m.data, dtype=float) for _, m in decoded[spec.COMMAND_RECEIPTS.topic]]
    receipts = [r for r in receipts if r.size % (1 + joint_count) == 0]
    latency = [
        v for _, m in decoded[spec.LEGACY_COMMAND_LATENCY.topic] for v in m.data
    ]  # bags from before the receipts
    receipts = np.concatenate(receipts).reshape(-1, 1 + joint_count) if receipts else np.zeros((0, 1 + joint_count))
    if len(receipts):
        latency = motor_latency_s(state, receipts).tolist()

    stamp = stamp_of

    diagnostics = []
    for _, msg in decoded[spec.DIAGNOSTICS.topic]:
        for status in msg.status:
            try:
                diagnostics.append((stamp(msg), float({kv.key: kv.value for kv in status.values}["jitter_p99_ms"])))
            except (KeyError, ValueError):
                pass

    def rows(values: list[np.ndarray]) -> np.ndarray:
        return np.vstack(values) if values else np.zeros((0, joint_count))

    return Recording(
        state=state,
        true_time_s=np.array([stamp(m) for _, m in true]),
        true_position=rows([np.asarray(m.position, float) for _, m in true]),
        true_velocity=rows([np.asarray(m.velocity, float) for _, m in true]),
        true_effort=rows([np.asarray(m.effort, float) for _, m in true]),
        counts=counts,
        receipt_s={k: np.asarray(v) * 1e-9 for k, v in receipt.items()},
        motor_latency_s=np.asarray(latency, dtype=float),
        reading_stamp_s=np.array([stamp(m) for _, m in readings]),
        reading_position=rows([np.asarray(m.position, float) for _, m in readings]),
        camera_time_s=np.array([t for t, _ in camera_std]),
        camera_position_std=rows([sigma for _, sigma in camera_std]),
        planned_time_s=np.array([t for t, _, _ in planned]),
        planned_position=rows([q for _, q, _ in planned]),
        planned_velocity=rows([v for _, _, v in planned]),
        brakes_time_s=np.array([t * 1e-9 for t, _, _ in brakes]),
        brakes=rows([b for _, b, _ in brakes]),
        brakes_reasons=[reasons for _, _, reasons in brakes],
        disturbance_time_s=np.array([t for t, _ in disturbance]),
        disturbance=rows([d for _, d in disturbance]),
        malformed=malformed,
        recorded_joint_names=_joint_names_of(true, joint_count),
        law_terms=law_terms,
        receipts=receipts,
        diagnostics=diagnostics,
    )


#: What scoring reads back (``blocks.spec``'s scored ports), and the diagnostics the view draws.
WANTED_TOPICS = (*spec.scored_topics(), spec.DIAGNOSTICS.topic, spec.CAMERA_READING.topic)


def _brake_reasons(msg: Any) -> frozenset[str]:
    """Why the brakes' state says they hold (``engaged:estop,requested``); empty if its label does not say."""
    return frozenset(brake_reasons(msg.layout.dim[0].label if msg.layout.dim else "") or ())


def _joint_count_of(decoded: dict[str, list[tuple[int, Any]]]) -> int:
    """The run's joint count: what most true-state messages carry (a stray one cannot change it)."""
    sizes = [len(msg.position) for _, msg in decoded[TRUE_STATE] if len(msg.position) > 0]
    if not sizes:
        raise ValueError(f"no {TRUE_STATE} with joint positions recorded")
    values, counts = np.unique(sizes, return_counts=True)
    return int(values[np.argmax(counts)])


def _law_terms(messages: list[Any], joint_count: int) -> dict[str, np.ndarray]:
    """The extra blocks of the controller's state by their layout labels (those after the standard ones)."""
    standard = len(state_layout.HEADER) + len(state_layout.FIELDS)
    rows = [
        state_layout.extra(msg.data, joint_count, [dim.label for dim in msg.layout.dim[standard:]]) for msg in messages
    ]
    names = list(dict.fromkeys(name for row in rows for name in row))
    nan = np.full(joint_count, np.nan)
    return {name: np.vstack([row.get(name, nan) for row in rows]) for name in names}


def _joint_names_of(true: list[tuple[int, Any]], joint_count: int) -> list[str]:
    """The names most true-state messages carry (empty if none names every joint)."""
    named = [tuple(msg.name) for _, msg in true if len(msg.name) == joint_count]
    if not named:
        return []
    return list(max(set(named), key=named.count))


def motor_latency_s(state: dict[str, np.ndarray], receipts: np.ndarray) -> np.ndarray:
    """Sensor stamp → command at the motor (s), per command the motor received."""
    return motor_latency(state["command"], state["measurement_stamp_s"], receipts)[1]


def motor_latency(commands: np.ndarray, stamps_s: np.ndarray, receipts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each receipt's time and its latency from the reading to the motor (s): a receipt row ``[receipt_time_s,
    command…]`` is paired with the latest tick (its command and measurement stamp) that issued the same command from
    a reading taken before the receipt."""
    stamps_by_command: dict[tuple[float, ...], list[float]] = {}
    for command, stamp in zip(map(tuple, np.asarray(commands).tolist()), np.asarray(stamps_s).tolist(), strict=True):
        stamps_by_command.setdefault(command, []).append(stamp)
    times, latency = [], []
    for row in np.asarray(receipts).tolist():
        stamps = stamps_by_command.get(tuple(row[1:]))
        if not stamps:
            continue  # a command from another publisher, or its tick not recorded
        index = bisect.bisect_right(stamps, row[0]) - 1  # stamps are in tick order
        if index >= 0:
            times.append(row[0])
            latency.append(row[0] - stamps[index])
    return np.asarray(times), np.asarray(latency)
