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
