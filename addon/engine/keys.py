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
    stack = [(0, n - 1)]
    while stack:
        a, b = stack.pop()
        if b - a < 2:
            continue
        x = np.arange(a + 1, b)
        line = y[a] + (y[b] - y[a]) * (x - a) / (b - a)
        err = np.abs(y[a + 1:b] - line)
        k = int(np.argmax(err))
        if err[k] > tolerance:
            m = a + 1 + k
            keep[m] = True
            stack.append((a, m))
            stack.append((m, b))
    return np.flatnonzero(keep)
