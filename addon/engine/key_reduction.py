"""Key reduction: fewer keyframes, same motion.

A key on every frame plays back exactly but is hard to edit.  :func:`reduce`
keeps the keys that a straight line between their neighbours could not
replace within ``tolerance`` (Ramer-Douglas-Peucker on the value axis), so
peaks, closures and holds survive and long smooth stretches lose their
in-between keys.  The first and last keys are always kept.
"""

from __future__ import annotations

import numpy as np


def reduce(values: np.ndarray, tolerance: float) -> np.ndarray:
    """Indices of the frames to key so that linear interpolation between them
    stays within ``tolerance`` of ``values`` at every frame."""
    y = np.asarray(values, dtype=float)
    n = len(y)
    if n <= 2 or tolerance <= 0:
        return np.arange(n)
    keep = np.zeros(n, dtype=bool)
    keep[0] = keep[-1] = True
    x = np.arange(n)
    # Every span between kept keys is split at once, at its first frame
    # farthest from the straight line over it, until none strays further
    # than ``tolerance``: the keys of the recursive algorithm, in a few
    # passes over the whole array instead of one small pass per key.
    while True:
        idx = np.flatnonzero(keep)
        span = np.minimum(np.searchsorted(idx, x, side="right") - 1, len(idx) - 2)
        a, b = idx[span], idx[span + 1]
        line = y[a] + (y[b] - y[a]) * (x - a) / (b - a)
        err = np.abs(y - line)
        err[keep] = 0.0
        worst = np.maximum.reduceat(err, idx[:-1])[span]
        split = np.flatnonzero((err == worst) & (worst > tolerance))
        if not len(split):
            return idx
        _, first = np.unique(span[split], return_index=True)
        keep[split[first]] = True
