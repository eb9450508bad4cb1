"""Gaussian smoothing along time, shared by the viseme curves, the learner
and the arousal track."""

from __future__ import annotations

import numpy as np


def gaussian(values: np.ndarray, sigma: float) -> np.ndarray:
    """``values`` (samples, or samples x columns) smoothed along the first
    axis by a Gaussian of ``sigma`` samples, cut at 3 sigma and normalised to
    sum 1.  The ends are padded with their edge values, so a constant stays
    constant.  Linear in ``values``: smoothing a blend equals blending the
    smoothed parts.  Every column is done at once, one kernel tap at a time,
    so the cost is (taps x size) whatever the number of columns."""
    x = np.asarray(values, dtype=float)
    if sigma <= 0 or len(x) == 0:
        return x.copy()
    radius = int(np.ceil(3 * sigma))
    kernel = np.exp(-0.5 * (np.arange(-radius, radius + 1) / sigma) ** 2)
    kernel /= kernel.sum()
    padded = np.pad(x, [(radius, radius)] + [(0, 0)] * (x.ndim - 1), mode="edge")
    n = len(x)
    out = kernel[0] * padded[:n]
    for k in range(1, len(kernel)):
        out += kernel[k] * padded[k:k + n]
    return out
