"""Viseme weights from pitch and intensity: equations 1 and 2 of
"Audio-driven Emotional Speech Animation".

For a phoneme p with mean pitch F_p and the clip's F_min, F_mean, F_max::

    W_F = W_p   + (F_p - F_mean) * (W_max - W_p) / (F_max - F_mean)   if F_p >= F_mean
    W_F = W_min + (F_p - F_min)  * (W_p - W_min) / (F_mean - F_min)   otherwise

and W_I the same with intensity.  Vowels take (W_F + W_I) / 2, plosives and
fricatives (and affricates, which are both) W_F.  The paper leaves nasals,
liquids and glides open: the preset's ``other_source`` chooses ("intensity",
"pitch", "both" or "neutral").  Values outside [min, max] are clamped, a flat
clip (F_max == F_mean) gives W_p instead of dividing by zero, and a phoneme
without pitch (whisper) falls back to W_p for W_F.
"""

from __future__ import annotations

import numpy as np

from .language.phonemes import MANNER


def piecewise(x, x_min: float, x_mean: float, x_max: float, w_min, w_p, w_max) -> np.ndarray:
    """Equation 1 (or 2): the weight for value(s) ``x``; NaN gives ``w_p``."""
    x = np.asarray(x, dtype=float)
    w_min = np.broadcast_to(np.asarray(w_min, float), x.shape)
    w_p = np.broadcast_to(np.asarray(w_p, float), x.shape)
    w_max = np.broadcast_to(np.asarray(w_max, float), x.shape)
    xc = np.clip(x, x_min, x_max)
    out = np.array(w_p, dtype=float, copy=True)
    up = np.isfinite(xc) & (xc >= x_mean)
    down = np.isfinite(xc) & (xc < x_mean)
    if x_max > x_mean:
        out[up] = w_p[up] + (xc[up] - x_mean) * (w_max[up] - w_p[up]) / (x_max - x_mean)
    if x_mean > x_min:
        out[down] = w_min[down] + (xc[down] - x_min) * (w_p[down] - w_min[down]) / (x_mean - x_min)
    return out


def phoneme_weights(phones: list[str], pitch: np.ndarray, intensity: np.ndarray, stats,
                    ranges: np.ndarray, other_source: str = "intensity") -> np.ndarray:
    """Weight of each phoneme's viseme.  ``ranges`` is (n, 3): W_min, W_p, W_max."""
    w_f = piecewise(pitch, stats.f_min, stats.f_mean, stats.f_max, ranges[:, 0], ranges[:, 1], ranges[:, 2])
    w_i = piecewise(intensity, stats.i_min, stats.i_mean, stats.i_max, ranges[:, 0], ranges[:, 1], ranges[:, 2])
    out = np.empty(len(phones))
    for k, p in enumerate(phones):
        manner = MANNER[p]
        if manner == "vowel":
            out[k] = (w_f[k] + w_i[k]) / 2
        elif manner in ("plosive", "fricative", "affricate"):
            out[k] = w_f[k]
        elif manner == "silence":
            out[k] = ranges[k, 1]
        else:
            out[k] = {"intensity": w_i[k], "pitch": w_f[k], "both": (w_f[k] + w_i[k]) / 2,
                      "neutral": ranges[k, 1]}[other_source]
    return np.clip(out, 0.0, 1.0)
