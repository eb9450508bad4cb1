"""The capture's delay to the sound.

Captures are rarely sample-aligned with the audio: a sensor system or a
camera starts late, or buffers.  The delay is the lag, within
``MAX_DELAY``, at which the measured tracks correlate best with what a
preset predicts from the sound (pooled over clips, mean over tracks), found
on a grid and refined by a parabola through the best three points.
Positive: the capture lags the sound.
"""

from __future__ import annotations

import numpy as np

from .evaluate import correlation

MAX_DELAY = 0.15
STEP = 0.0025


def score(preds: list[np.ndarray], clips, delay: float) -> float:
    """Mean over tracks of the pooled correlation at ``delay``."""
    P = np.concatenate(preds)
    Y = np.concatenate([c.aligned(delay) for c in clips])
    rs = [correlation(P[:, j], Y[:, j]) for j in range(Y.shape[1])]
    rs = [r for r in rs if r is not None]
    return float(np.mean(rs)) if rs else 0.0


def estimate(preds: list[np.ndarray], clips, max_delay: float = MAX_DELAY, step: float = STEP
             ) -> tuple[float, float]:
    """(delay in s, the correlation it reaches)."""
    lags = np.arange(-max_delay, max_delay + step / 2, step)
    s = np.array([score(preds, clips, d) for d in lags])
    k = int(np.argmax(s))
    d = float(lags[k])
    if 0 < k < len(lags) - 1:
        a, b, c = s[k - 1], s[k], s[k + 1]
        den = a - 2 * b + c
        if den < 0:
            d += float(np.clip(0.5 * (a - c) / den, -0.5, 0.5)) * step
    return d, float(s[k])
