"""How close predicted tracks come to measured ones."""

from __future__ import annotations

import numpy as np


def rmse_report(pred: list[np.ndarray], meas: list[np.ndarray], channels: list[str]) -> dict:
    Y = np.concatenate(meas)
    E = np.concatenate(pred) - Y
    sst = ((Y - Y.mean(axis=0)) ** 2).sum()
    return {"rmse": float(np.sqrt((E ** 2).mean())),
            "variance_explained": float(1.0 - (E ** 2).sum() / sst) if sst > 0 else None,
            "rmse_per_channel": {c: round(float(np.sqrt((E[:, j] ** 2).mean())), 5) for j, c in enumerate(channels)}}


def correlation(a: np.ndarray, b: np.ndarray) -> float | None:
    """Pearson correlation of two tracks (None when either is flat)."""
    a, b = a - a.mean(), b - b.mean()
    den = float(np.sqrt((a * a).sum() * (b * b).sum()))
    return float((a * b).sum() / den) if den > 1e-12 else None


def track_correlation(pred: np.ndarray, meas: np.ndarray) -> float | None:
    """Correlation of a prediction with a measured track: None when the
    measured track does not move, 0 when it moves and the prediction does not."""
    if float(np.ptp(meas)) <= 1e-9:
        return None
    c = correlation(pred, meas)
    return 0.0 if c is None else c


def extrema(y: np.ndarray, half: int, prominence: float) -> list[tuple[int, int]]:
    """(frame, +1 for a peak / -1 for a trough) where ``y`` is the highest or
    lowest within ``half`` frames either side and stands out by at least
    ``prominence`` from the other extreme of that window."""
    out = []
    for i in range(len(y)):
        lo, hi = max(0, i - half), min(len(y), i + half + 1)
        win = y[lo:hi]
        if y[i] >= win.max() and y[i] - win.min() >= prominence and (i == 0 or y[i - 1] < y[i]):
            out.append((i, 1))
        elif y[i] <= win.min() and win.max() - y[i] >= prominence and (i == 0 or y[i - 1] > y[i]):
            out.append((i, -1))
    return out


def peak_timing(pred: np.ndarray, meas: np.ndarray, fps: float, window: float = 0.12) -> float | None:
    """Mean time in ms between each clear peak or trough of the measured
    track (an opening, a closure) and the same extreme of the prediction
    within ``window`` s of it; None when the track has none."""
    half = max(1, int(round(window * fps)))
    spread = float(np.percentile(meas, 95) - np.percentile(meas, 5))
    if spread <= 1e-9:
        return None
    errs = []
    for i, sign in extrema(meas, half, 0.3 * spread):
        lo, hi = max(0, i - half), min(len(pred), i + half + 1)
        j = lo + int(np.argmax(sign * pred[lo:hi]))
        errs.append(abs(j - i) / fps * 1000.0)
    return float(np.mean(errs)) if errs else None


def track_scores(pred: np.ndarray, meas: np.ndarray, fps: float) -> dict:
    """Correlation, RMSE and peak-timing error (ms) of one track."""
    c = track_correlation(pred, meas)
    pt = peak_timing(pred, meas, fps)
    return {"correlation": None if c is None else round(c, 4),
            "rmse": round(float(np.sqrt(((pred - meas) ** 2).mean())), 5),
            "peak_timing_ms": None if pt is None else round(pt, 1)}
