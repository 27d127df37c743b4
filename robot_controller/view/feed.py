"""The loop's signals turned into what the view logs, at a rate a browser takes: ``ViewFeed`` collects raw samples
(live topics or a bag's arrays); ``flush`` thins them (``Decimator``: series at most ``SERIES_HZ``, poses ``POSE_HZ``,
by time buckets, errors and timing keeping each bucket's largest so that a spike is never thinned away) into rerun
columns held by an ``Outlet`` per recording stream (the live browser, the saved file). The camera's image with its
detections (JPEG, a few a second) is logged as it is, each at its exposure."""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable

import numpy as np

from robot_controller.core.controller import state_layout
from robot_controller.scoring import bag_reader, report
from robot_controller.view import layout
from robot_controller.view.arm import Arm

SERIES_HZ = 50.0
POSE_HZ = 20.0
MAX_PENDING = 5000  # per input: 50 s of a 100 Hz topic
MAX_PENDING_IMAGES = 25  # the camera's images waiting for the first tick (5 s at 5 Hz): the newest kept
TICK_TAIL = 400  # controller ticks kept to pair true samples and motor receipts with (4 s at 100 Hz)
OTHER_CLOCK_S = 60.0  # a diagnostics stamp this far outside the ticks' span is on another clock
STATUS_NAMES = {code: name for name, code in state_layout.STATUS_CODES.items()}


class Decimator:
    """At most ``rate_hz`` samples a second of one series, by time buckets, one sample each (the newest bucket is
    held back until a later sample starts the next one, or ``final``)."""

    def __init__(self, rate_hz: float, *, extreme: bool = False) -> None:
        self.period = 1.0 / rate_hz
        self.extreme = extreme
        self.t = np.zeros(0)
        self.v: np.ndarray | None = None

    def take(self, t: np.ndarray, v: np.ndarray, *, final: bool = False) -> tuple[np.ndarray, np.ndarray]:
        t = np.concatenate([self.t, np.asarray(t, dtype=float)])
        v = np.asarray(v, dtype=float) if self.v is None else np.concatenate([self.v, np.asarray(v, dtype=float)])
        if len(t) == 0:
            self.t, self.v = t, v
            return t, v
        bucket = np.floor(t / self.period)
        done = np.ones(len(t), bool) if final else bucket < bucket[-1]
        self.t, self.v = t[~done], v[~done]
        t, v, bucket = t[done], v[done], bucket[done]
        if len(t) == 0:
            return t, v
        starts = np.flatnonzero(np.r_[True, bucket[1:] != bucket[:-1]])
        if not self.extreme:
            return t[starts], v[starts]
        magnitude = np.abs(v) if v.ndim == 1 else np.max(np.abs(v), axis=1)
        magnitude = np.where(np.isfinite(magnitude), magnitude, -1.0)
        ends = np.r_[starts[1:], len(t)]
        pick = np.array([s + int(np.argmax(magnitude[s:e])) for s, e in zip(starts, ends, strict=False)])
        return t[pick], v[pick]


class Outlet:
    """Columns for one recording stream, held per entity and sent every ``period_s`` (one chunk per entity each time:
    few, larger chunks keep a file small, a browser quick and the sender's CPU low; ``0`` sends at every flush). The
    arm's poses go every ``pose_period_s`` (default: the same)."""

    def __init__(self, rec, period_s: float = 0.0, pose_period_s: float | None = None) -> None:
        self.rec = rec
        self.period_s = period_s
        self.pose_period_s = period_s if pose_period_s is None else pose_period_s
        self.next_send = self.next_pose_send = 0.0
        self.scalars: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {}
        self.arm: Arm | None = None
        self.poses: list[tuple[np.ndarray, np.ndarray]] = []  #: (t (m,), q (m, poses, joints))

    def add_scalars(self, path: str, t: np.ndarray, v: np.ndarray) -> None:
        self.scalars.setdefault(path, []).append((t, v))

    def add_poses(self, arm: Arm, t: np.ndarray, q: np.ndarray) -> None:
        self.arm = arm
        self.poses.append((t, q))

    def text(self, path: str, t: float, text: str, level: str) -> None:
        import rerun as rr

        self.rec.set_time(layout.TIMELINE, duration=t)
        self.rec.log(path, rr.TextLog(text, level=level))

    def image(self, path: str, t: float, data: bytes, media_type: str) -> None:
        """An encoded image (``image/jpeg``…) at ``t``, logged now (a few a second: nothing to gather)."""
        import rerun as rr

        self.rec.set_time(layout.TIMELINE, duration=t)
        self.rec.log(path, rr.EncodedImage(contents=data, media_type=media_type))

    def show(self, blueprint) -> None:
        """Lay the view out anew (the camera's image came): the layout a reset goes back to, too."""
        self.rec.send_blueprint(blueprint, make_active=True, make_default=True)

    def pump(self, now: float, *, force: bool = False) -> None:
        """Send what is held if its period has passed since the last send (or ``force``)."""
        import rerun as rr

        if force or now >= self.next_send:
            self.next_send = now + self.period_s
            for path, parts in self.scalars.items():
                t, v = np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])
                time = [rr.TimeColumn(layout.TIMELINE, duration=t)]
                self.rec.send_columns(path, indexes=time, columns=rr.Scalars.columns(scalars=v))
            self.scalars.clear()
        if (force or now >= self.next_pose_send) and self.poses:
            self.next_pose_send = now + self.pose_period_s
            t, q = np.concatenate([p[0] for p in self.poses]), np.concatenate([p[1] for p in self.poses])
            time = [rr.TimeColumn(layout.TIMELINE, duration=t)]
            for path, columns in self.arm.pose_columns(layout.ARM, q):
                self.rec.send_columns(path, indexes=time, columns=columns)
            self.poses.clear()


def reference_in_force(
    ticks: np.ndarray, reference: np.ndarray, status: np.ndarray, t: np.ndarray, nominal_period_s: float
) -> np.ndarray:
    """The controller's reference in force at each time ``t`` (NaN where none is), as scoring defines it."""
    in_force, valid = report.reference_in_force_at(ticks, reference, status, t, nominal_period_s)
    in_force[~valid] = np.nan
    return in_force


class ViewFeed:
    """Collects the loop's samples and hands them, thinned, to its outlets on ``flush``."""

    def __init__(self, outlets: list[Outlet], arm: Arm, *, nominal_period_s: float, live: bool = True) -> None:
        self.outlets = outlets
        self.arm = arm
        self.joints = arm.joint_names
        self.n = len(self.joints)
        self.nominal_period_s = nominal_period_s
        self.live = live
        self.t0: float | None = None  #: the first controller tick: time 0 of the view
        pending = (lambda: deque(maxlen=MAX_PENDING)) if live else list
        self.true_in, self.measured_in, self.state_in = pending(), pending(), pending()
        self.planned_in, self.receipts_in, self.diagnostics_in = pending(), pending(), pending()
        self.images_in = deque(maxlen=MAX_PENDING_IMAGES) if live else []
        self.camera_shown = not live  #: live, the layout gains the camera's view when its first image comes
        self.decimators: dict[str, Decimator] = {}
        # The controller's recent ticks: time, status, reference, command, reading stamp.
        self.ticks = np.zeros(0)
        self.tick_status = np.zeros(0)
        self.tick_reference = np.zeros((0, self.n))
        self.tick_command = np.zeros((0, self.n))
        self.tick_stamp = np.zeros(0)
        self.readings_t = np.zeros(0)  #: the sensor's recent readings (for the measured arm)
        self.readings_q = np.zeros((0, self.n))
        self.unpaired_t = np.zeros(0)  #: true samples newer than the last tick: paired at a later flush
        self.unpaired_q = np.zeros((0, self.n))
        self.last_status: int | None = None

    def true_state(self, t: float, q: Iterable[float], effort: Iterable[float]) -> None:
        self.true_in.append((t, *q, *effort))

    def measured(self, t: float, q: Iterable[float]) -> None:
        self.measured_in.append((t, *q))

    def controller_state(self, data: Iterable[float]) -> None:
        row = state_layout.standard(tuple(data), self.n)  # a law's extra terms after the standard ones: not drawn
        if row is None:
            return  # not the run's layout: dropped
        if self.t0 is None:
            self.t0 = row[0]
        self.state_in.append(row)

    def planned(self, t: float, q: Iterable[float]) -> None:
        self.planned_in.append((t, *q))

    def receipts(self, rows: np.ndarray) -> None:
        rows = np.asarray(rows, dtype=float)
        if rows.size % (1 + self.n):
            return  # not [receipt_time_s, command…] rows: dropped
        for row in rows.reshape(-1, 1 + self.n):
            self.receipts_in.append(tuple(row))

    def diagnostics(self, t: float, jitter_p99_ms: float) -> None:
        self.diagnostics_in.append((t, jitter_p99_ms))

    def detections(self, t: float, data: bytes, image_format: str = "jpeg") -> None:
        """The camera's image with its detections drawn, compressed (``image_format``: ``jpeg`` or ``png``)."""
        if data:
            self.images_in.append((t, bytes(data), media_type(image_format)))

    def _decimate(
        self, key: str, rate_hz: float, t: np.ndarray, v: np.ndarray, *, extreme: bool = False, final: bool = False
    ) -> tuple[np.ndarray, np.ndarray]:
        decimator = self.decimators.get(key)
        if decimator is None:
            decimator = self.decimators[key] = Decimator(rate_hz, extreme=extreme)
        return decimator.take(t, v, final=final)

    def _series(
        self, series: str, joint: str, t: np.ndarray, v: np.ndarray, *, extreme: bool = False, final: bool = False
    ) -> None:
        path = layout.series_path(series, joint, self.n)
        t, v = self._decimate(path, SERIES_HZ, t, v, extreme=extreme, final=final)
        keep = np.isfinite(v)
        if np.any(keep):
            for outlet in self.outlets:
                outlet.add_scalars(path, t[keep] - self.t0, v[keep])

    def _per_joint(self, series: str, t: np.ndarray, values: np.ndarray, **options: bool) -> None:
        """One series per joint: ``values`` has a column per joint."""
        for k, joint in enumerate(self.joints):
            self._series(series, joint, t, values[:, k], **options)

    def _poses(self, t: np.ndarray, q: np.ndarray, final: bool) -> None:
        """The three arms, one row at the true samples' instants (at most ``POSE_HZ``): the measured as the latest
        reading then, the reference interpolated between ticks (a ghost not known yet sits on the true arm)."""
        t, q = self._decimate("poses", POSE_HZ, t, q, final=final)
        if len(t) == 0:
            return
        measured, reference = q.copy(), q.copy()
        if len(self.readings_t):
            index = np.searchsorted(self.readings_t, t, side="right") - 1
            seen = index >= 0
            measured[seen] = self.readings_q[index[seen]]
        if len(self.ticks):
            reference = np.column_stack([np.interp(t, self.ticks, self.tick_reference[:, k]) for k in range(self.n)])
        for outlet in self.outlets:
            outlet.add_poses(self.arm, t - self.t0, np.stack([q, measured, reference], axis=1))

    @staticmethod
    def _drain(queue, width: int) -> np.ndarray | None:
        """What ``queue`` holds, as rows of ``width`` values (rows of another width are dropped)."""
        rows = [r for r in queue if len(r) == width]
        queue.clear()
        return np.array(rows, dtype=float) if rows else None

    def flush(self, now: float = 0.0, *, final: bool = False) -> None:
        """Take what came in since the last flush, and send what each outlet holds if its period is up at ``now``
        (monotonic seconds). ``final``: everything, no bucket held back, every outlet sent."""
        if self.t0 is not None:  # else nothing can be placed on the timeline yet
            self._take(final)
        for outlet in self.outlets:
            outlet.pump(now, force=final)

    def _take(self, final: bool) -> None:
        n = self.n
        states = self._drain(self.state_in, state_layout.width(n))
        if states is not None:
            self._controller(states, final)
        measured = self._drain(self.measured_in, 1 + n)
        if measured is not None:
            self._per_joint("measured", measured[:, 0], measured[:, 1:], final=final)
            keep = slice(-TICK_TAIL if self.live else None, None)
            self.readings_t = np.concatenate([self.readings_t, measured[:, 0]])[keep]
            self.readings_q = np.vstack([self.readings_q, measured[:, 1:]])[keep]
        true = self._drain(self.true_in, 1 + 2 * n)
        if true is not None:
            t, q, effort = true[:, 0], true[:, 1 : 1 + n], true[:, 1 + n :]
            self._poses(t, q, final)
            self._per_joint("true", t, q, final=final)
            self._per_joint("applied", t, effort, final=final)
            self.unpaired_t = np.concatenate([self.unpaired_t, t])
            self.unpaired_q = np.vstack([self.unpaired_q, q])
        self._tracking_error(final)
        planned = self._drain(self.planned_in, 1 + n)
        if planned is not None:
            self._per_joint("planned", planned[:, 0], planned[:, 1:], final=final)
        receipts = self._drain(self.receipts_in, 1 + n)
        if receipts is not None and len(self.ticks):
            self._latency(receipts, final)
        self._images()
        diagnostics = self._drain(self.diagnostics_in, 2)
        if diagnostics is not None and len(self.ticks):
            # Stamped on another clock than the ticks (the wall clock's, on sim time): left out, or plots span years.
            t = diagnostics[:, 0]
            near = (t >= self.t0 - OTHER_CLOCK_S) & (t <= self.ticks[-1] + OTHER_CLOCK_S)
            if np.any(near):
                self._series("jitter_p99", self.joints[0], t[near], diagnostics[near, 1], final=True)

    def _images(self) -> None:
        images = list(self.images_in)
        self.images_in.clear()
        if images and not self.camera_shown:
            self.camera_shown = True
            for outlet in self.outlets:
                outlet.show(layout.blueprint(self.arm, live=self.live, camera=True))
        for t, data, kind in images:
            for outlet in self.outlets:
                outlet.image(layout.DETECTIONS, t - self.t0, data, kind)

    def _controller(self, states: np.ndarray, final: bool) -> None:
        s = state_layout.decode(states, self.n)
        t = s["time_s"]
        self._per_joint("reference", t, s["reference"], final=final)
        self._per_joint("error_controller", t, 1e3 * s["error"], extreme=True, final=final)
        self._per_joint("commanded", t, s["command"], final=final)
        # Each tick's period against the nominal one, from the previous tick (kept from the last flush).
        all_t = np.concatenate([self.ticks[-1:], t])
        jitter = 1e3 * np.abs(np.diff(all_t) - self.nominal_period_s)
        self._series("jitter", self.joints[0], all_t[1:], jitter, extreme=True, final=final)
        # Status changes, as a log line each.
        codes = s["status"].astype(int)
        previous = np.concatenate([[self.last_status if self.last_status is not None else -1], codes[:-1]])
        for k in np.flatnonzero(codes != previous):
            name = STATUS_NAMES.get(int(codes[k]), str(codes[k]))
            level = "INFO" if name in ("ok", "reacquiring") else "WARN"
            for outlet in self.outlets:
                outlet.text(layout.STATUS_LOG, float(t[k] - self.t0), f"controller: {name}", level)
        self.last_status = int(codes[-1])
        keep = slice(-TICK_TAIL if self.live else None, None)
        self.ticks = np.concatenate([self.ticks, t])[keep]
        self.tick_status = np.concatenate([self.tick_status, s["status"]])[keep]
        self.tick_reference = np.vstack([self.tick_reference, s["reference"]])[keep]
        self.tick_command = np.vstack([self.tick_command, s["command"]])[keep]
        self.tick_stamp = np.concatenate([self.tick_stamp, s["measurement_stamp_s"]])[keep]

    def _tracking_error(self, final: bool) -> None:
        """Reference in force − true position for every true sample the ticks cover."""
        if not len(self.ticks) or not len(self.unpaired_t):
            return
        # A sample is paired once a later tick has come (or the run is over).
        ready = np.ones(len(self.unpaired_t), bool) if final else self.unpaired_t <= self.ticks[-1]
        t, q = self.unpaired_t[ready], self.unpaired_q[ready]
        held = ~ready
        self.unpaired_t, self.unpaired_q = self.unpaired_t[held][-MAX_PENDING:], self.unpaired_q[held][-MAX_PENDING:]
        if not len(t):
            return
        in_force = reference_in_force(self.ticks, self.tick_reference, self.tick_status, t, self.nominal_period_s)
        self._per_joint("error_true", t, 1e3 * (in_force - q), extreme=True, final=final)

    def _latency(self, receipts: np.ndarray, final: bool) -> None:
        """Reading stamp → command at the motor, per receipt matched to the tick that issued its command."""
        t, latency = bag_reader.motor_latency(self.tick_command, self.tick_stamp, receipts)
        if len(t):
            order = np.argsort(t)
            self._series("latency", self.joints[0], t[order], 1e3 * latency[order], extreme=True, final=final)


def media_type(image_format: str) -> str:
    """The media type of a ``sensor_msgs/CompressedImage`` of ``format`` (``jpeg``, ``png``, or cv_bridge's
    ``bgr8; jpeg compressed bgr8``)."""
    return "image/png" if "png" in image_format.lower() else "image/jpeg"
