"""Thinning a series for a browser: at most so many samples a second, by time buckets, taking either each bucket's first
sample or, for errors and timing, its sample of largest magnitude (so a spike is never thinned away)."""

from __future__ import annotations

import numpy as np


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
