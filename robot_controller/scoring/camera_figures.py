"""A camera's figures from the bag (``--sensing camera`` or ``both``): its rate, the frames in which no marker was
found, how often every joint was seen, and how long each joint ran on the arm's model for want of a marker."""

from __future__ import annotations

from typing import Any

import numpy as np


def camera_figures(camera_time_s: np.ndarray, position_std: np.ndarray, joint_names: list[str]) -> dict[str, Any]:
    """``metrics.json``'s camera keys from each frame's exposure (s) and σ per joint (``inf``: unseen)."""
    frames = int(camera_time_s.size)
    if frames == 0:
        return {"camera_frames": 0}
    seen = np.isfinite(position_std)
    span_s = float(camera_time_s[-1] - camera_time_s[0])
    period_s = span_s / (frames - 1) if frames > 1 else float("nan")
    unseen_s = {}
    for j, name in enumerate(joint_names[: seen.shape[1]]):
        if not seen[:, j].all():
            unseen_s[name] = round(float((~seen[:, j]).sum()) * period_s, 3)
    return {
        "camera_frames": frames,
        "camera_rate_hz": round(1.0 / period_s, 3) if frames > 1 and period_s > 0 else None,
        "camera_frames_lost": int((~seen.any(axis=1)).sum()),
        "camera_detection_rate": round(float(seen.all(axis=1).mean()), 4),
        "camera_unseen_s": unseen_s,
    }


def camera_line(values: dict[str, Any]) -> str | None:
    """The summary's sensing row, or None on encoders alone."""
    sensing = values.get("sensing", "encoders")
    if sensing == "encoders":
        return None
    frames = values.get("camera_frames", 0)
    what = "a camera" if sensing == "camera" else "encoders and a camera fused"
    if not frames:
        return f"{what}: no camera frame recorded"
    rate = values.get("camera_rate_hz")
    text = f"{what} at {rate:.1f} Hz: {frames} frames, {values['camera_frames_lost']} lost (no marker found)"
    text += f", every joint seen in {values['camera_detection_rate'] * 100:.1f} % of them"
    if unseen := values.get("camera_unseen_s"):
        text += "; on the arm's model for want of a marker: " + ", ".join(f"{n} {s:.2f} s" for n, s in unseen.items())
    return text
