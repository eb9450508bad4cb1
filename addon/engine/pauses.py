"""The mouth rests in pauses.

The coarticulation models blend every segment with its neighbours, so a
speech viseme leaks into a pause and the mouth never quite returns to rest
between phrases.  Here every pause of the alignment (a gap between phones of
at least ``rest.min_pause`` seconds, ``data/timing.json``) is forced to the
rest pose: the curves fall to zero over ``rest.ramp`` seconds after the last
phone and rise again over the same time before the next one, and stay at
zero in between.
"""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path

import numpy as np

DATA = Path(__file__).parent / "data" / "timing.json"


@lru_cache(maxsize=1)
def settings() -> dict:
    with open(DATA, encoding="utf-8") as fh:
        return json.load(fh)


def gaps(spans: list[tuple[float, float]], duration: float, min_pause: float) -> list[tuple[float, float]]:
    """Stretches of at least ``min_pause`` s with no phone in them, the
    silence before the first phone and after the last one included."""
    out = []
    t = 0.0
    for a, b in sorted(spans):
        if a - t >= min_pause:
            out.append((t, a))
        t = max(t, b)
    if duration - t >= min_pause:
        out.append((t, duration))
    return out


def rest_envelope(times: np.ndarray, pauses: list[tuple[float, float]], ramp: float,
                  duration: float) -> np.ndarray:
    """Per frame, 1 where the mouth may move and 0 where it must rest; the
    edges of a pause ramp linearly over ``ramp`` s (none at the clip's ends)."""
    env = np.ones(len(times))
    for a, b in pauses:
        lo, hi = np.searchsorted(times, [a, b])
        if b >= duration - 1e-9:
            hi = len(times)   # a pause that ends the clip holds its last frame too
        t = times[lo:hi]
        into = (t - a) / ramp if a > 1e-9 else np.full(len(t), np.inf)
        out_of = (b - t) / ramp if b < duration - 1e-9 else np.full(len(t), np.inf)
        env[lo:hi] = np.minimum(env[lo:hi], np.clip(1.0 - np.minimum(into, out_of), 0.0, 1.0))
    return env


def force_rest(curves: np.ndarray, times: np.ndarray, spans: list[tuple[float, float]],
               duration: float) -> np.ndarray:
    """``curves`` with every pause of the phone ``spans`` at rest (module docstring)."""
    return curves * rest_for(times, spans, duration)[:, None]


def rest_for(times: np.ndarray, spans: list[tuple[float, float]], duration: float) -> np.ndarray:
    """:func:`rest_envelope` of the pauses between the phone ``spans``, with
    the ``rest`` settings of ``data/timing.json``."""
    cfg = settings()["rest"]
    return rest_envelope(times, gaps(spans, duration, cfg["min_pause"]), cfg["ramp"], duration)
