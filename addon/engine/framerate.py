"""Frame rates and the frame clock.

Frame rates come from users as ``24``, ``"29.97"`` or ``"30000/1001"``;
:func:`parse_fps` reads each of them (broadcast rates written with two
decimals mean the exact NTSC ratios), and :func:`frame_times` gives the time
of every frame of a line.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from .errors import LipSyncError

#: Broadcast rates written with two decimals mean the NTSC ratios.
_NTSC = {23.976: Fraction(24000, 1001), 29.97: Fraction(30000, 1001), 59.94: Fraction(60000, 1001),
         47.952: Fraction(48000, 1001), 119.88: Fraction(120000, 1001)}


def parse_fps(value) -> float:
    """``"29.97"`` -> 30000/1001; ``"24000/1001"`` and plain numbers work too."""
    try:
        if isinstance(value, str) and "/" in value:
            a, b = value.split("/")
            fps = float(Fraction(int(a), int(b)))
        else:
            fps = float(value)
            for k, v in _NTSC.items():
                if abs(fps - k) < 0.006:
                    fps = float(v)
    except (ValueError, ZeroDivisionError):
        raise LipSyncError(f"frame rate {value!r} is not a number") from None
    if not (1.0 <= fps <= 1000.0):
        raise LipSyncError(f"frame rate {value!r} is out of range (1-1000 fps)")
    return fps


def frame_times(duration: float, fps: float) -> np.ndarray:
    """The time (s) of every frame from 0 to ``duration``, both included."""
    return np.arange(int(np.floor(duration * fps + 1e-9)) + 1) / fps
