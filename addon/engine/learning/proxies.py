"""What measured tracks mean, and how a preset predicts them.

A track is one of three kinds:

* a shape key (or ARKit blendshape): the fit learns each viseme's pose as a
  mix of these, as the engine animates a rig;
* an articulatory proxy, ``jaw``, ``lip_aperture`` or ``rounding``
  (articulography, landmark tracking): a viseme predicts it through the
  table ``data/articulation/proxies.json``;
* a viseme, ``viseme:NAME``: the viseme's own curve predicts it.

Proxies and visemes are in the capture's own units: each track gets a gain
and an offset (its calibration, fitted on the training clips for each
preset alike), so the fit is judged on the shape and timing of the motion.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import LipSyncError
from ..language.phonemes import SILENCE

TABLE = Path(__file__).resolve().parent.parent / "data" / "articulation" / "proxies.json"
VISEME_PREFIX = "viseme:"


def _table() -> tuple[list[str], dict[str, list[float]]]:
    d = json.loads(TABLE.read_text(encoding="utf-8"))
    return list(d["channels"]), d["phonemes"]


PROXIES = tuple(_table()[0])


def kind(channel: str) -> str:
    """``proxy``, ``viseme`` or ``shape_key``."""
    if channel in PROXIES:
        return "proxy"
    if channel.startswith(VISEME_PREFIX):
        return "viseme"
    return "shape_key"


def is_calibrated(channels: list[str]) -> bool:
    """True when the tracks are proxies or visemes (predicted through fixed
    poses and a calibration); False for shape keys (poses are learned).
    A mix of the two is refused."""
    kinds = {kind(c) != "shape_key" for c in channels}
    if len(kinds) > 1:
        raise LipSyncError("the tracks mix shape keys with proxies or visemes ("
                           f"{', '.join(c for c in channels if kind(c) != 'shape_key')}); learn from one kind")
    return kinds == {True}


def poses(vset, channels: list[str]) -> np.ndarray:
    """(visemes, channels): what each viseme contributes to each proxy or
    viseme track."""
    names, table = _table()
    M = np.zeros((len(vset.visemes), len(channels)))
    for j, ch in enumerate(channels):
        if kind(ch) == "viseme":
            v = ch[len(VISEME_PREFIX):]
            if v not in vset.visemes:
                raise LipSyncError(f"track {ch!r}: the {vset.name!r} viseme set has no viseme {v!r} "
                                   f"(it has {', '.join(vset.visemes)})")
            M[vset.index(v), j] = 1.0
            continue
        k = names.index(ch)
        total, count = np.zeros(len(vset.visemes)), np.zeros(len(vset.visemes))
        for phone, vals in table.items():
            shown = vset.of(phone) if phone in vset.phonemes else []
            for v in shown:
                total[vset.index(v)] += vals[k]
                count[vset.index(v)] += 1
        rest = vset.rest
        if rest and count[vset.index(rest)] == 0:
            total[vset.index(rest)], count[vset.index(rest)] = table[SILENCE][k], 1
        M[:, j] = np.where(count > 0, total / np.maximum(count, 1), 0.0)
    return M


def calibrate(preds: list[np.ndarray], meas: list[np.ndarray], weights: list[np.ndarray] | None = None
              ) -> tuple[np.ndarray, np.ndarray]:
    """Per-track gain and offset mapping predictions onto measurements
    (weighted least squares over all the clips)."""
    X = np.concatenate(preds)
    Y = np.concatenate(meas)
    W = np.concatenate(weights) if weights is not None else np.ones_like(Y)
    gain, offset = np.zeros(Y.shape[1]), np.zeros(Y.shape[1])
    for j in range(Y.shape[1]):
        w = W[:, j]
        sw = max(w.sum(), 1e-12)
        mx, my = (w * X[:, j]).sum() / sw, (w * Y[:, j]).sum() / sw
        vx = (w * (X[:, j] - mx) ** 2).sum()
        gain[j] = (w * (X[:, j] - mx) * (Y[:, j] - my)).sum() / vx if vx > 1e-12 else 0.0
        offset[j] = my - gain[j] * mx
    return gain, offset
