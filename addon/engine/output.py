"""What a lip-sync run gives back, and the files it writes.

:class:`Result` holds everything :func:`.pipeline.analyze` found (the
alignment, the voice measurements, the curves) and writes it as the JSON
document docs/output.md describes (``schema`` 1) or as a CSV frame table.
:func:`check_output_path` checks a file can be written before any work.
"""

from __future__ import annotations

import csv
import json
import os
from dataclasses import dataclass, field

import numpy as np

from . import arousal as arousal_mod
from . import gestures as gestures_mod
from . import visemes
from .alignment import Alignment
from .errors import LipSyncError

SCHEMA_VERSION = 1


def beyond_script(al: Alignment) -> str:
    """How far a take strayed from its script, in one line ("" when it did
    not): words recognised with no transcript, transcript words not heard,
    seconds of unscripted speech."""
    parts = []
    if al.words and all(w.recognized for w in al.words):
        parts.append(f"{len(al.words)} word{'s' if len(al.words) != 1 else ''} recognised (no transcript)")
    unheard = sum(not w.spoken for w in al.words)
    if unheard:
        parts.append(f"{unheard} word{'s' if unheard != 1 else ''} of the transcript not heard")
    if al.unscripted:
        parts.append(f"{sum(b - a for a, b, _ in al.unscripted):.1f} s of unscripted speech")
    return "; ".join(parts)


def _word(w) -> dict:
    """A word of the JSON document.  ``spoken`` (false: a transcript word
    the audio does not hold) and ``recognized`` (true: heard, not read in a
    transcript) appear only when they differ from a transcript word's."""
    out = {"word": w.text, "start": round(w.start, 4), "end": round(w.end, 4),
           "estimated": bool(w.estimated), "pronunciation": w.source or None}
    if not w.spoken:
        out["spoken"] = False
    if w.recognized:
        out["recognized"] = True
    return out


@dataclass
class Result:
    """Everything :func:`.pipeline.analyze` found, and the curves."""

    duration: float
    fps: float
    viseme_set: visemes.VisemeSet
    emotion: str               # the preset the line starts with
    model: str                 # the coarticulation model
    alignment: Alignment
    pitch: np.ndarray          # per phoneme, Hz (NaN: no pitch)
    intensity: np.ndarray      # per phoneme, dB
    weights: np.ndarray        # per phoneme
    times: np.ndarray          # per frame, s
    curves: np.ndarray         # (frames, visemes) in [0, 1]
    notes: list[str] = field(default_factory=list)
    closure: np.ndarray = field(default_factory=lambda: np.zeros(0))  # per frame: lips closed (/p b m/), 0-1
    #: The notes a user must see (printed as warnings): words left out, a guessed encoding.
    warnings: list[str] = field(default_factory=list)
    arousal: arousal_mod.Estimate | None = None   # how excited the voice sounds, -1 to 1
    emotions: list[dict] = field(default_factory=list)  # the emotion over time (inline tags, markers)
    #: The expression on the whole face: FACS action unit -> per frame, 0-1 (none under neutral).
    expression: dict[str, np.ndarray] = field(default_factory=dict)
    language: str = "en"       # the transcript's language (its code in data/languages.json)
    #: Blinks, gaze, head and brows beside speech (None: turned off).
    gestures: gestures_mod.Motion | None = None

    def to_dict(self) -> dict:
        al = self.alignment
        return {
            "schema": SCHEMA_VERSION,
            "duration": round(self.duration, 6),
            "fps": self.fps,
            "viseme_set": self.viseme_set.name,
            "emotion": self.emotion,
            "coarticulation": self.model,
            "language": self.language,
            "visemes": list(self.viseme_set.visemes),
            "words": [_word(w) for w in al.words],
            "phonemes": [{"phone": p.phone, "start": round(p.start, 4), "end": round(p.end, 4),
                          "word_index": p.word_index,
                          "pitch_hz": None if not np.isfinite(f) else round(float(f), 2),
                          "intensity_db": round(float(i), 2), "weight": round(float(w), 4),
                          "estimated": bool(p.estimated)}
                         for p, f, i, w in zip(al.phones, self.pitch, self.intensity, self.weights)],
            "frames": {"time": [round(float(t), 6) for t in self.times],
                       "weights": np.round(self.curves, 4).tolist(),
                       "closure": np.round(self.closure, 4).tolist()},
            "notes": self.notes,
            "arousal": self.arousal.to_dict() if self.arousal is not None else None,
            "emotions": self.emotions or [{"emotion": self.emotion, "time": 0.0, "fade": None}],
            "expression": {unit: np.round(v, 4).tolist() for unit, v in self.expression.items()},
            "unscripted": [{"start": round(a, 4), "end": round(b, 4), "text": t} for a, b, t in al.unscripted],
            "gestures": self.gestures.to_dict() if self.gestures is not None else None,
        }

    def write_json(self, path: str | os.PathLike) -> None:
        # Encoded whole before the file is opened: json.dumps uses the C
        # encoder (json.dump to a file does not; 4 against 13 ms on a 27 s
        # line), and a value that cannot be encoded leaves no partial file.
        text = json.dumps(self.to_dict(), separators=(",", ":"))
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(text)

    def write_csv(self, path: str | os.PathLike) -> None:
        """The frame table: frame, time, one column per viseme, then one per
        expression action unit (none under neutral), then the gestures'
        tracks (:data:`.gestures.Motion.TRACKS`; none when turned off)."""
        units = list(self.expression)
        tracks = self.gestures.tracks() if self.gestures is not None else {}
        with open(path, "w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh)
            w.writerow(["frame", "time"] + list(self.viseme_set.visemes) + units + list(tracks))
            for k, (t, row) in enumerate(zip(self.times, self.curves)):
                w.writerow([k, f"{t:.6f}"] + [f"{x:.4f}" for x in row]
                           + [f"{self.expression[u][k]:.4f}" for u in units]
                           + [f"{v[k]:.4f}" for v in tracks.values()])


def check_output_path(path: str | os.PathLike, what: str = "output", inputs=()) -> None:
    """Raise :class:`LipSyncError` now, before any work, if ``path`` cannot
    be written: its folder is missing or not a folder, it is a folder, it is
    read-only, or it is one of the ``inputs`` (which writing would destroy)."""
    path = os.path.abspath(os.fspath(path))
    folder = os.path.dirname(path)
    if os.path.isdir(path):
        raise LipSyncError(f"{what} {path} is a folder; give a file name")
    if not os.path.exists(folder):
        raise LipSyncError(f"cannot write {what} {path}: the folder {folder} does not exist")
    if not os.path.isdir(folder):
        raise LipSyncError(f"cannot write {what} {path}: {folder} is not a folder")
    for other in inputs:
        if other and os.path.exists(other) and os.path.exists(path) and os.path.samefile(path, other):
            raise LipSyncError(f"{what} {path} is also an input; writing it would replace it")
    if os.path.exists(path):
        if not os.access(path, os.W_OK):
            raise LipSyncError(f"cannot write {what} {path}: the file is read-only")
    elif not os.access(folder, os.W_OK | os.X_OK):
        raise LipSyncError(f"cannot write {what} {path}: no permission to write in {folder}")
