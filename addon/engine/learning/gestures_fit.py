"""The gestures' numbers measured on a face capture (see :mod:`..gestures`).

An ARKit capture carries the eyelids (``eyeBlinkLeft``/``Right``) and the
gaze (``eyeLook*``); Live Link Face also records the head's rotation
(``HeadYaw``, ``HeadPitch``, ``HeadRoll``, radians), read by
:func:`.capture.read_head_csv` into :attr:`.data.TrainingClip.head`.  What
the clips show is measured, not fitted through the synthesis: each number
of the preset's ``gestures`` section has its own measure, and only the
numbers the clips hold enough of are given (at least three blinks, gaze
channels that move, head angles):

* ``blink_rate`` (blinks a minute: the lids, both eyes' mean, rising past
  half closed), ``blink_duration`` (their time above half closed, over the
  share of a blink the layer's shape spends there), ``blink_at_pauses``
  (the share starting within 0.35 s of a pause between words);
* ``gaze_range`` (the spread of the gaze's yaw), ``gaze_down`` (its median
  below level), ``gaze_interval`` (the time between saccades: the gaze
  turning faster than 100 degrees a second), the look keys read at
  ``look_range`` degrees in full (``data/gestures.json``);
* ``head_range`` (the spread of the head's pitch while speaking, degrees)
  and ``pause_calm`` (its angular speed in pauses of 0.5 s or more, against
  speech).
"""

from __future__ import annotations

import numpy as np

from .. import gestures
from ..presets import GESTURE_RANGES

#: The share of a blink the gesture layer's lids spend above half closed.
ABOVE_HALF = 0.61
SACCADE = 100.0     # degrees a second
NEAR_PAUSE = 0.35   # s


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(int), [0]])))
    return list(zip(edges[::2], edges[1::2]))


def _clip(name: str, value: float) -> float:
    lo, hi = GESTURE_RANGES[name]
    return round(float(min(max(value, lo), hi)), 3)


def measure(clips, channels: list[str]) -> dict:
    """The gestures' numbers the clips show.  ``clips`` holds (frame times,
    (frames, channels) values, alignment, head angles (frames, 3) degrees
    or None).  Returns {"values": {field: number}, "evidence": {...}};
    {"values": {}} when the capture shows none of them."""
    idx = {c: k for k, c in enumerate(channels)}
    lids_at = [idx[c] for c in ("eyeBlinkLeft", "eyeBlinkRight") if c in idx]
    look = {c: idx[c] for c in channels if c.startswith("eyeLook")}
    rng = gestures.table()["look_range"]
    values: dict[str, float] = {}
    evidence: dict[str, float] = {}
    seconds = sum(float(t[-1] - t[0]) for t, *_ in clips if len(t) > 1)
    starts, lengths, near = [], [], []
    yaw, pitch, saccades = [], [], 0
    head_spread, speed_talk, speed_rest = [], [], []
    for times, y, al, head in clips:
        y = np.asarray(y, dtype=float)
        dt = float(np.median(np.diff(times))) if len(times) > 1 else 1.0
        pauses = gestures.pauses(al)
        if lids_at:
            lids = y[:, lids_at].mean(axis=1)
            for a, b in _runs(lids > 0.5):
                starts.append(times[a])
                lengths.append((b - a) * dt)
                near.append(any(p - NEAR_PAUSE <= times[a] <= q + NEAR_PAUSE for p, q in pauses))
        if len(look) >= 4:
            def ch(name, y=y):
                return y[:, look[name]] if name in look else np.zeros(len(y))
            gy = rng["horizontal"] * (ch("eyeLookOutLeft") - ch("eyeLookInLeft") + ch("eyeLookInRight")
                                      - ch("eyeLookOutRight")) / 2
            gp = rng["vertical"] * (ch("eyeLookUpLeft") + ch("eyeLookUpRight") - ch("eyeLookDownLeft")
                                    - ch("eyeLookDownRight")) / 2
            yaw.append(gy)
            pitch.append(gp)
            fast = np.hypot(np.diff(gy), np.diff(gp)) / dt > SACCADE
            saccades += len(_runs(fast))
        if head is not None and len(head) == len(times):
            talking = np.zeros(len(times), dtype=bool)
            for w in al.words:
                if w.spoken:
                    talking |= (times >= w.start) & (times < w.end)
            resting = np.zeros(len(times), dtype=bool)
            for a, b in pauses:
                if b - a >= 0.5:
                    resting |= (times >= a) & (times < b)
            h = np.asarray(head, dtype=float)
            if talking.sum() > 10:
                head_spread.append(float(np.std(h[talking, 0] - np.mean(h[:, 0]))))
            sp = np.linalg.norm(np.diff(h, axis=0), axis=1) / dt
            speed_talk += list(sp[talking[1:]])
            speed_rest += list(sp[resting[1:]])
    if len(starts) >= 3 and seconds > 0:
        values["blink_rate"] = _clip("blink_rate", len(starts) / seconds * 60)
        values["blink_duration"] = _clip("blink_duration", float(np.mean(lengths)) / ABOVE_HALF)
        values["blink_at_pauses"] = _clip("blink_at_pauses", float(np.mean(near)))
        evidence["blinks"] = len(starts)
    if yaw:
        gy, gp = np.concatenate(yaw), np.concatenate(pitch)
        if np.ptp(gy) > 0.5 or np.ptp(gp) > 0.5:
            values["gaze_range"] = _clip("gaze_range", float(np.std(gy)))
            values["gaze_down"] = _clip("gaze_down", -float(np.median(gp)))
            if saccades:
                values["gaze_interval"] = _clip("gaze_interval", seconds / saccades)
            evidence["saccades"] = saccades
    if head_spread:
        values["head_range"] = _clip("head_range", float(np.mean(head_spread)))
        if speed_rest and speed_talk:
            values["pause_calm"] = _clip("pause_calm", float(np.mean(speed_rest)) / max(float(np.mean(speed_talk)),
                                                                                        1e-9))
        evidence["head_clips"] = len(head_spread)
    return {"values": values, "evidence": evidence}


__all__ = ["measure"]
