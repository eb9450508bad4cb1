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

Any other per-frame CSV (articulography, landmark tracking) is read with a
track map naming which columns are the jaw, lip-aperture and rounding
proxies or visemes, and how to scale them: :func:`read_track_csv`.
"""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import numpy as np

from ..conventions import canonical
from ..errors import ImportFormatError
from .proxies import PROXIES, VISEME_PREFIX

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


def _time_column(lower: list[str]) -> tuple[int | None, bool]:
    """The time column among lower-cased header names, and whether it holds
    timecodes (else seconds); None when there is none."""
    if "timecode" in lower:
        return lower.index("timecode"), True
    return next((lower.index(n) for n in _TIME_SECONDS if n in lower), None), False


def _read_rows(path: Path, what: str) -> tuple[list[list[str]], list[str]]:
    """The non-blank rows of a per-frame CSV after its header, and the header."""
    if not path.is_file():
        raise ImportFormatError(f"{what} file not found: {path}")
    with open(path, newline="", encoding="utf-8-sig") as fh:
        rows = [r for r in csv.reader(fh) if any(c.strip() for c in r)]
    if len(rows) < 3:
        raise ImportFormatError(f"{path}: needs a header row and at least two frames")
    return rows[1:], [h.strip() for h in rows[0]]


def _read_frames(path: Path, rows: list[list[str]], width: int, t_col: int, is_tc: bool, fps: float,
                 unit: float, cols: list[tuple[int, str, list | None]]) -> tuple[np.ndarray, np.ndarray]:
    """(times in s from the first row, values) of ``rows``: the time from
    column ``t_col`` (a timecode, or a number times ``unit``), and for each
    (column, name, range) of ``cols`` its value, mapped so that range [a, b]
    becomes [0, 1] when a range is given.  Every row must have ``width``
    cells, every value must be a finite number and time must increase."""
    times = np.empty(len(rows))
    values = np.empty((len(rows), len(cols)))
    for i, row in enumerate(rows):
        where = f"{path}, line {i + 2}"
        if len(row) != width:
            raise ImportFormatError(f"{where}: {len(row)} values, but the header has {width} columns")
        try:
            times[i] = _timecode(row[t_col], fps, where) if is_tc else float(row[t_col]) * unit
        except ValueError:
            raise ImportFormatError(f"{where}: time {row[t_col]!r} is not a number") from None
        for j, (k, name, rng) in enumerate(cols):
            try:
                v = float(row[k])
            except ValueError:
                raise ImportFormatError(f"{where}: {name} = {row[k]!r} is not a number") from None
            values[i, j] = v if rng is None else (v - rng[0]) / (rng[1] - rng[0])
    if not np.all(np.isfinite(values)) or not np.all(np.isfinite(times)):
        raise ImportFormatError(f"{path}: holds NaN or infinite values")
    if np.any(np.diff(times) <= 0):
        k = int(np.flatnonzero(np.diff(times) <= 0)[0])
        raise ImportFormatError(f"{path}, line {k + 3}: time does not increase ({times[k + 1]:.4f} s after "
                                f"{times[k]:.4f} s)")
    return times - times[0], values


def read_capture_csv(path: str | Path, fps: float = 60.0) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """(times in s from the first row, values (rows, channels), ARKit channel names)."""
    path = Path(path)
    rows, header = _read_rows(path, "capture")
    t_col, is_tc = _time_column([h.lower() for h in header])
    if t_col is None:
        raise ImportFormatError(f"{path}: no time column (Timecode, or time / seconds in seconds); "
                                f"the header is {', '.join(header[:6])}{' ...' if len(header) > 6 else ''}")
    cols = [(k, _BY_CANON[canonical(h)], None) for k, h in enumerate(header) if canonical(h) in _BY_CANON]
    if not cols:
        raise ImportFormatError(f"{path}: no ARKit blendshape columns (jawOpen, mouthClose, ...)")
    names = [n for _k, n, _r in cols]
    if len(set(names)) != len(names):
        raise ImportFormatError(f"{path}: a blendshape appears twice in the header")
    times, values = _read_frames(path, rows, len(header), t_col, is_tc, fps, 1.0, cols)
    return times, values, names


#: Live Link Face's head rotation columns (radians), in the order of
#: :attr:`.data.TrainingClip.head` (pitch, yaw, roll).
HEAD = ("headpitch", "headyaw", "headroll")


def read_head_csv(path: str | Path, fps: float = 60.0) -> np.ndarray | None:
    """The head's rotation a capture CSV records (``HeadPitch``, ``HeadYaw``,
    ``HeadRoll`` in radians, as Live Link Face writes them), in degrees,
    (rows, 3); None when it has no such columns."""
    path = Path(path)
    rows, header = _read_rows(path, "capture")
    lower = [canonical(h) for h in header]
    if not all(h in lower for h in HEAD):
        return None
    t_col, is_tc = _time_column([h.lower() for h in header])
    cols = [(lower.index(h), h, None) for h in HEAD]
    _times, values = _read_frames(path, rows, len(header), t_col, is_tc, fps, 1.0, cols)
    return np.degrees(values)


# --- generic per-frame tracks ----------------------------------------------------------

TRACK_MAP_HELP = ("a JSON file or COLUMN=TRACK[,COLUMN=TRACK...] (and time=COLUMN, time_unit=ms); TRACK is "
                  "jaw, lip_aperture, rounding or viseme:NAME")


def load_track_map(spec: str) -> dict:
    """A column mapping for :func:`read_track_csv`: a JSON file::

        {"time": "t_ms", "time_unit": "ms",
         "columns": {"JawY": {"track": "jaw", "range": [0, 20]},
                     "LA": {"track": "lip_aperture", "range": [0, 15]},
                     "UL_x": "rounding", "p_aa": "viseme:aa"}}

    or the same inline: ``time=t_ms,time_unit=ms,JawY=jaw,LA=lip_aperture``.  ``range``
    [a, b] maps a to 0 and b to 1 (b below a turns a track over); without
    it values are used as they are.  ``time`` names the time column
    (default: ``time`` / ``seconds`` / ``Timecode`` as for ARKit captures),
    ``time_unit`` is ``s`` (default) or ``ms``."""
    path = Path(spec)
    if path.suffix.lower() == ".json" or path.is_file():
        if not path.is_file():
            raise ImportFormatError(f"track map not found: {path}")
        try:
            m = json.loads(path.read_text(encoding="utf-8-sig"))
        except (ValueError, UnicodeDecodeError) as exc:
            raise ImportFormatError(f"{path}: not valid JSON ({exc})") from None
        where = str(path)
    else:
        m, where = {"columns": {}}, "track map"
        for part in spec.split(","):
            if "=" not in part:
                raise ImportFormatError(f"track map {spec!r}: {part!r} is not COLUMN=TRACK")
            k, v = (x.strip() for x in part.split("=", 1))
            if k in ("time", "time_unit"):
                m[k] = v
            else:
                m["columns"][k] = v
    if not isinstance(m, dict) or not isinstance(m.get("columns"), dict) or not m["columns"]:
        raise ImportFormatError(f"{where}: needs \"columns\": {{column: track}}")
    out = {"time": m.get("time"), "time_unit": m.get("time_unit", "s"), "columns": {}}
    if out["time_unit"] not in ("s", "ms"):
        raise ImportFormatError(f"{where}: time_unit must be \"s\" or \"ms\"")
    for col, spec_ in m["columns"].items():
        spec_ = {"track": spec_} if isinstance(spec_, str) else spec_
        track = spec_.get("track") if isinstance(spec_, dict) else None
        if not isinstance(track, str) or not (track in PROXIES or (track.startswith(VISEME_PREFIX)
                                                                    and len(track) > len(VISEME_PREFIX))):
            raise ImportFormatError(f"{where}: column {col!r} maps to {track!r}; a track is "
                                    f"{', '.join(PROXIES)} or viseme:NAME")
        rng = spec_.get("range")
        if rng is not None and not (isinstance(rng, list) and len(rng) == 2
                                    and all(isinstance(x, (int, float)) for x in rng) and rng[0] != rng[1]):
            raise ImportFormatError(f"{where}: column {col!r}: range must be two different numbers [a, b]")
        out["columns"][col] = (track, rng)
    tracks = [t for t, _r in out["columns"].values()]
    if len(set(tracks)) != len(tracks):
        raise ImportFormatError(f"{where}: two columns map to the same track")
    return out


def read_track_csv(path: str | Path, track_map: dict, fps: float = 60.0
                   ) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """(times in s from the first row, values (rows, tracks), track names)
    from any per-frame CSV whose columns ``track_map`` names
    (:func:`load_track_map`)."""
    path = Path(path)
    rows, header = _read_rows(path, "track")
    tname = track_map.get("time")
    if tname:
        if tname not in header:
            raise ImportFormatError(f"{path}: no time column {tname!r}; the header is {', '.join(header[:8])}")
        t_col, is_tc = header.index(tname), False
    else:
        t_col, is_tc = _time_column([h.lower() for h in header])
        if t_col is None:
            raise ImportFormatError(f"{path}: no time column (name it in the track map's \"time\")")
    unit = 0.001 if track_map.get("time_unit") == "ms" else 1.0
    cols, tracks = [], []
    for col, (track, rng) in track_map["columns"].items():
        if col not in header:
            raise ImportFormatError(f"{path}: no column {col!r}; the header is {', '.join(header[:8])}"
                                    f"{' ...' if len(header) > 8 else ''}")
        cols.append((header.index(col), col, rng))
        tracks.append(track)
    times, values = _read_frames(path, rows, len(header), t_col, is_tc, fps, unit, cols)
    return times, values, tracks
