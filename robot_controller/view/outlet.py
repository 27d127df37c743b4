"""Where the view's thinned columns go: one ``Outlet`` per rerun recording stream (the live browser, the saved file)."""

from __future__ import annotations

import numpy as np

from robot_controller.view import layout
from robot_controller.view.arm import Arm


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
