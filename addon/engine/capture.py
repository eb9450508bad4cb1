"""Face-capture tracks from CSV, as ARKit face capture apps (Live Link Face
and others) record them.

Accepted layout: a header row, then one row per captured frame.

* A time column, named ``Timecode`` (``HH:MM:SS:FF`` or ``HH:MM:SS:FF.fff``
  at the capture's frame rate, as Live Link Face writes it), or ``time`` /
  ``seconds`` / ``time_s`` (seconds).  Times are made relative to the first
  row: the capture must start with the audio.
* One column per ARKit blendshape, by its ARKit name in any case
  (``jawOpen``, ``JawOpen`` and ``jaw_open`` are the same), values 0-1.
* Other columns (``BlendShapeCount``, head and eye rotations, anything else)
  are ignored.
"""

from __future__ import annotations

import csv
import re
from pathlib import Path

import numpy as np

from .errors import ImportFormatError
from .conventions import canonical

ARKIT = ("eyeBlinkLeft eyeLookDownLeft eyeLookInLeft eyeLookOutLeft eyeLookUpLeft eyeSquintLeft eyeWideLeft "
         "eyeBlinkRight eyeLookDownRight eyeLookInRight eyeLookOutRight eyeLookUpRight eyeSquintRight "
         "eyeWideRight jawForward jawLeft jawRight jawOpen mouthClose mouthFunnel mouthPucker mouthLeft "
         "mouthRight mouthSmileLeft mouthSmileRight mouthFrownLeft mouthFrownRight mouthDimpleLeft "
         "mouthDimpleRight mouthStretchLeft mouthStretchRight mouthRollLower mouthRollUpper mouthShrugLower "
         "mouthShrugUpper mouthPressLeft mouthPressRight mouthLowerDownLeft mouthLowerDownRight "
         "mouthUpperUpLeft mouthUpperUpRight browDownLeft browDownRight browInnerUp browOuterUpLeft "
         "browOuterUpRight cheekPuff cheekSquintLeft cheekSquintRight noseSneerLeft noseSneerRight "
         "tongueOut").split()
_BY_CANON = {canonical(n): n for n in ARKIT}
_TIME_SECONDS = ("time", "seconds", "time_s", "times", "t")
_TIMECODE = re.compile(r"^(\d+):(\d\d):(\d\d)[:;](\d+)(?:\.(\d+))?$")


def _timecode(text: str, fps: float, where: str) -> float:
    m = _TIMECODE.match(text.strip())
    if not m:
        raise ImportFormatError(f"{where}: timecode {text!r} is not HH:MM:SS:FF(.fff)")
    h, mi, s, f, sub = m.groups()
    frames = int(f) + (float("0." + sub) if sub else 0.0)
    return int(h) * 3600 + int(mi) * 60 + int(s) + frames / fps


def read_capture_csv(path: str | Path, fps: float = 60.0) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """(times in s from the first row, values (rows, channels), ARKit channel names)."""
    path = Path(path)
    if not path.is_file():
        raise ImportFormatError(f"capture file not found: {path}")
    with open(path, newline="", encoding="utf-8-sig") as fh:
        rows = list(csv.reader(fh))
    rows = [r for r in rows if any(c.strip() for c in r)]
    if len(rows) < 3:
        raise ImportFormatError(f"{path}: needs a header row and at least two frames")
    header = [h.strip() for h in rows[0]]
    lower = [h.lower() for h in header]
    if "timecode" in lower:
        t_col, is_tc = lower.index("timecode"), True
    else:
        t_col = next((lower.index(n) for n in _TIME_SECONDS if n in lower), None)
        is_tc = False
        if t_col is None:
            raise ImportFormatError(f"{path}: no time column (Timecode, or time / seconds in seconds); "
                                    f"the header is {', '.join(header[:6])}{' ...' if len(header) > 6 else ''}")
    cols = [(k, _BY_CANON[canonical(h)]) for k, h in enumerate(header) if canonical(h) in _BY_CANON]
    if not cols:
        raise ImportFormatError(f"{path}: no ARKit blendshape columns (jawOpen, mouthClose, ...)")
    names = [n for _k, n in cols]
    if len(set(names)) != len(names):
        raise ImportFormatError(f"{path}: a blendshape appears twice in the header")
    times = np.empty(len(rows) - 1)
    values = np.empty((len(rows) - 1, len(cols)))
    for i, row in enumerate(rows[1:]):
        line = i + 2
        if len(row) != len(header):
            raise ImportFormatError(f"{path}, line {line}: {len(row)} values, but the header has {len(header)} "
                                    "columns")
        where = f"{path}, line {line}"
        if is_tc:
            times[i] = _timecode(row[t_col], fps, where)
        else:
            try:
                times[i] = float(row[t_col])
            except ValueError:
                raise ImportFormatError(f"{where}: time {row[t_col]!r} is not a number") from None
        for j, (k, n) in enumerate(cols):
            try:
                values[i, j] = float(row[k])
            except ValueError:
                raise ImportFormatError(f"{where}: {n} = {row[k]!r} is not a number") from None
    if not np.all(np.isfinite(values)):
        raise ImportFormatError(f"{path}: holds NaN or infinite values")
    if np.any(np.diff(times) <= 0):
        k = int(np.flatnonzero(np.diff(times) <= 0)[0])
        raise ImportFormatError(f"{path}, line {k + 3}: time does not increase ({times[k + 1]:.4f} s after "
                                f"{times[k]:.4f} s)")
    return times - times[0], values, names
