"""The numbers the viewer needs, read straight from a message's CDR bytes (a Python message per each of ~400 messages a
second cost more than the rest of its work). Plain CDR (XCDR1), either byte order; alignment counts from the end of
the 4-byte encapsulation header."""

from __future__ import annotations

import struct

import numpy as np


class _Reader:
    def __init__(self, data: bytes) -> None:
        if len(data) < 4:
            raise ValueError("CDR: shorter than its header")
        self.data = data
        self.e = "<" if data[1] & 1 else ">"
        self.pos = 4

    def align(self, n: int) -> None:
        self.pos += (-(self.pos - 4)) % n

    def u32(self, code: str = "I") -> int:
        """A 4-byte integer (``code`` ``I`` unsigned, ``i`` signed)."""
        self.align(4)
        (value,) = struct.unpack_from(self.e + code, self.data, self.pos)
        self.pos += 4
        return value

    def skip_string(self) -> None:
        n = self.u32()
        self.pos += n

    def string(self) -> str:
        n = self.u32()
        text = self.data[self.pos : self.pos + n].rstrip(b"\0").decode("utf-8", "replace")
        self.pos += n
        return text

    def doubles(self) -> np.ndarray:
        n = self.u32()
        if n:
            self.align(8)
        if self.pos + 8 * n > len(self.data):
            raise ValueError("CDR: sequence runs past the end")
        out = np.frombuffer(self.data, dtype=self.e + "f8", count=n, offset=self.pos)
        self.pos += 8 * n
        return out


def joint_state(data: bytes) -> tuple[float, list[str], np.ndarray, np.ndarray]:
    """``sensor_msgs/JointState``: stamp (s), names, positions, efforts.

    :raises ValueError, struct.error: not a JointState's bytes
    """
    r = _Reader(data)
    sec, nanosec = r.u32("i"), r.u32()
    r.skip_string()  # frame_id
    names = [r.string() for _ in range(r.u32())]
    position = r.doubles()
    r.doubles()  # velocity
    effort = r.doubles()
    return sec + nanosec * 1e-9, names, position, effort


def float64_array(data: bytes) -> np.ndarray:
    """``std_msgs/Float64MultiArray``: its data (the layout is skipped).

    :raises ValueError, struct.error: not a Float64MultiArray's bytes
    """
    r = _Reader(data)
    for _ in range(r.u32()):  # layout.dim
        r.skip_string()  # label
        r.u32()  # size
        r.u32()  # stride
    r.u32()  # layout.data_offset
    return r.doubles()
