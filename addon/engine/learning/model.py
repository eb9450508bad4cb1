"""The model the fit adjusts: the dominance blend of each clip's viseme
events with its derivatives in the log-parameters, the poses solved by
ridge regression, and the engine's full synthesis path for evaluation."""

from __future__ import annotations

import copy

import numpy as np

from .. import coarticulation, mapping
from ..phonemes import CLASSES
from .data import Prepared

PARAMS = ("alpha", "theta", "phi", "c")
#: Bounds of the fitted parameters (the log of these bounds the search).
BOUNDS = {"alpha": (0.02, 50.0), "theta": (1.0, 250.0), "phi": (1.0, 250.0), "c": (0.5, 2.0)}
REFERENCE_CLASS = "vowel"       # its alpha is held: the blend depends on alpha ratios only


class Model:
    """The dominance blend of one set of clips, and its derivatives."""

    def __init__(self, clips: list[Prepared], fps: float, sigma: float, free: list[tuple[int, int]]):
        self.clips, self.fps, self.sigma, self.free = clips, fps, sigma, free

    def blend(self, P: np.ndarray, want_jac: bool):
        """Smoothed blends C (frames, visemes) per clip, and dC/dq for the
        free log-parameters q (list of (frames, visemes) arrays per clip)."""
        out, jacs = [], []
        for c in self.clips:
            par = P[c.cls]                                     # (segments, 4)
            d = c.times[None, :] - c.centres[:, None]
            dist = np.maximum(np.abs(d) - c.half[:, None], 0.0)
            before = d < 0
            rate = np.where(before, par[:, 1:2], par[:, 2:3])
            dc = dist ** par[:, 3:4]
            D = par[:, 0:1] * np.exp(-rate * dc)
            S = np.maximum(D.sum(axis=0), 1e-300)
            C = (D.T @ c.targets) / S[:, None]
            out.append(coarticulation.smooth(C, self.fps, self.sigma))
            if not want_jac:
                continue
            with np.errstate(divide="ignore", invalid="ignore"):
                logd = np.where(dist > 0, np.log(np.where(dist > 0, dist, 1.0)), 0.0)
            G = {0: D,
                 1: -par[:, 1:2] * dc * D * before,
                 2: -par[:, 2:3] * dc * D * ~before,
                 3: -rate * par[:, 3:4] * dc * logd * D}
            cj = []
            for k, p in self.free:
                m = c.cls == k
                if not m.any():
                    cj.append(None)
                    continue
                g = G[p][m]
                dC = (g.T @ c.targets[m] - C * g.sum(axis=0)[:, None]) / S[:, None]
                cj.append(coarticulation.smooth(dC, self.fps, self.sigma))
            jacs.append(cj)
        return out, jacs


def solve_poses(blends, zs, ridge, prior):
    """Poses A minimising sum ||C A - Z||^2 + lam ||A - prior||^2, with lam
    ``ridge`` times the mean of diag(C^T C): a viseme the clips barely show
    stays near the viseme set's own pose instead of fitting the noise."""
    CtC = sum(C.T @ C for C in blends)
    CtZ = sum(C.T @ Z for C, Z in zip(blends, zs))
    n = CtC.shape[0]
    lam = ridge * max(float(np.trace(CtC)) / n, 1e-12)
    return np.linalg.solve(CtC + lam * np.eye(n), CtZ + lam * prior)


def params_matrix(preset: dict) -> np.ndarray:
    cl = preset["dominance"]["classes"]
    return np.array([[cl[c][p] for p in PARAMS] for c in CLASSES], float)


def synthesise(clip: Prepared, preset: dict, vset, channels: list[str], fps: float,
               mp: dict[str, dict[str, float]]) -> np.ndarray:
    """Tracks the engine makes for a prepared clip (the full synthesis path)."""
    from ..pipeline import curves

    al = copy.copy(clip.alignment)
    al.duration = float(clip.times[-1]) if len(clip.times) else al.duration
    _w, times, out = curves(al, clip.pitch, clip.intensity, clip.stats, vset, preset, "dominance", fps)
    names, values = mapping.shape_key_curves(out, vset.visemes, mp)
    res = np.zeros((len(clip.times), len(channels)))
    n = min(len(times), len(clip.times))
    for j, c in enumerate(channels):
        if c in names:
            res[:n, j] = values[:n, names.index(c)]
    return res
