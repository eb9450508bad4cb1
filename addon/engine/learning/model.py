"""The model the fit adjusts: the dominance blend of each clip's viseme
events with its derivatives in the log-parameters, the poses solved by
ridge regression, and the engine's full synthesis path for evaluation."""

from __future__ import annotations

import copy

import numpy as np

from .. import coarticulation, mapping
from ..language import CLASSES
from ..presets import Preset, as_preset
from ..render import curves
from .data import Prepared

PARAMS = ("alpha", "theta", "phi", "c")
#: Bounds of the fitted parameters (the log of these bounds the search).
BOUNDS = {"alpha": (0.02, 50.0), "theta": (1.0, 250.0), "phi": (1.0, 250.0), "c": (0.5, 2.0)}
REFERENCE_CLASS = "vowel"       # its alpha is held: the blend depends on alpha ratios only


class Model:
    """The dominance blend of one set of clips, and its derivatives."""

    def __init__(self, clips: list[Prepared], fps: float, sigma: float, free: list[tuple[int, int]],
                 strength: float = 0.0):
        self.clips, self.fps, self.sigma, self.free = clips, fps, sigma, free
        self.strength = strength

    def _smooth(self, columns: np.ndarray) -> np.ndarray:
        """The engine's curve smoothing (:func:`..coarticulation.smooth`)."""
        return coarticulation.smooth(columns, self.fps, self.sigma)

    def blend(self, P: np.ndarray, want_jac: bool):
        """Smoothed blends C (frames, visemes) per clip, and dC/dq for the
        free log-parameters q per clip, as (frames, free, visemes)."""
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
            Cs = self._smooth(C) * c.rest[:, None]
            masks = _closure_masks(Cs, c.closures, self.strength)
            Cs = _apply(Cs, masks, True)
            capped = []   # (frames, viseme) held at a closure cap: no derivative there
            for v, (frames, cap) in (c.caps or {}).items():
                capped.append((frames[Cs[frames, v] > cap], v))
                Cs[frames, v] = np.minimum(Cs[frames, v], cap)
            out.append(Cs)
            if not want_jac:
                continue
            with np.errstate(divide="ignore", invalid="ignore"):
                logd = np.where(dist > 0, np.log(np.where(dist > 0, dist, 1.0)), 0.0)
            G = {0: D,
                 1: -par[:, 1:2] * dc * D * before,
                 2: -par[:, 2:3] * dc * D * ~before,
                 3: -rate * par[:, 3:4] * dc * logd * D}
            R = np.zeros((len(c.times), len(self.free), C.shape[1]))
            for i, (k, p) in enumerate(self.free):
                m = c.cls == k
                if m.any():
                    g = G[p][m]
                    R[:, i, :] = (g.T @ c.targets[m] - C * g.sum(axis=0)[:, None]) / S[:, None]
            # The smoothing is linear, so the derivative of the smoothed blend is the smoothed derivative.
            R = self._smooth(R.reshape(len(c.times), -1)).reshape(R.shape) * c.rest[:, None, None]
            R = _apply(R, masks, False)
            for frames, v in capped:
                R[frames, :, v] = 0.0
            jacs.append(R)
        return out, jacs


def _closure_masks(C: np.ndarray, closures, strength: float):
    """The engine's closure step (:func:`..coarticulation.enforce_closures`)
    as masks: per closure, (lo, hi, viseme, scale of every viseme, where
    the viseme keeps its own value, the value it is raised to)."""
    masks = []
    if not closures or strength <= 0:
        return masks
    cur = C.copy()
    for lo, hi, v, w, suppress, raise_ in closures:
        scale = 1.0 - strength * suppress
        own = cur[lo:hi, v].copy()
        floor = w * raise_
        keep = own >= floor
        cur[lo:hi] *= scale[:, None]
        cur[lo:hi, v] = np.where(keep, own, floor)
        masks.append((lo, hi, v, scale, keep, floor))
    return masks


def _apply(C: np.ndarray, masks, values: bool) -> np.ndarray:
    """Apply the closure masks to curves (``values``) or to their
    derivatives (frames first, visemes last; a raised value does not move)."""
    if not masks:
        return C
    out = C.copy()
    for lo, hi, v, scale, keep, floor in masks:
        sh = (hi - lo,) + (1,) * (C.ndim - 1)
        own = out[lo:hi, ..., v].copy()
        out[lo:hi] *= scale.reshape(sh)
        k = keep.reshape(sh[:-1]) if C.ndim > 2 else keep
        raised = floor.reshape(sh[:-1]) if (values and C.ndim > 2) else (floor if values else 0.0)
        out[lo:hi, ..., v] = np.where(k, own, raised)
    return out


def solve_poses(blends, zs, ridge, prior, frames: float = 0.0):
    """Poses A minimising sum ||C A - Z||^2 + lam ||A - prior||^2, with lam
    ``frames`` plus ``ridge`` times the mean of diag(C^T C): a viseme the
    clips barely show stays near the starting pose instead of fitting the
    noise (the pull is as strong as ``frames`` frames of the viseme shown
    in full, so the less the clips show a viseme, the more it keeps)."""
    CtC = sum(C.T @ C for C in blends)
    CtZ = sum(C.T @ Z for C, Z in zip(blends, zs))
    n = CtC.shape[0]
    lam = frames + ridge * max(float(np.trace(CtC)) / n, 1e-12)
    return np.linalg.solve(CtC + lam * np.eye(n), CtZ + lam * prior)


def bounded_poses(blends, ys, prior: np.ndarray, frames: float, lo: float = 0.0, hi: float = 1.0) -> np.ndarray:
    """(visemes, tracks) poses minimising sum ||C M - Y||^2 + frames ||M - prior||^2
    with every value in [lo, hi] (the range a rig's shape key shows).  The
    problem is convex and separate per track: an active-set solve per
    track (values past a bound are held there, a held value whose gradient
    points inside is released), then coordinate-descent sweeps, which only
    lower the cost, to finish."""
    n = blends[0].shape[1]
    lam = max(frames, 1e-9)
    H = sum(C.T @ C for C in blends) + lam * np.eye(n)
    B = sum(C.T @ Y for C, Y in zip(blends, ys)) + lam * np.asarray(prior, float)
    M = np.empty_like(B)
    for j in range(B.shape[1]):
        b = B[:, j]
        held = np.zeros(n, bool)
        x = np.zeros(n)
        for _ in range(4 * n):
            f = ~held
            x_f = np.linalg.solve(H[np.ix_(f, f)], b[f] - H[np.ix_(f, held)] @ x[held]) if f.any() else x[f]
            out = (x_f < lo) | (x_f > hi)
            x[f] = np.clip(x_f, lo, hi)
            if out.any():
                idx = np.flatnonzero(f)[out]
                held[idx] = True
                continue
            g = H @ x - b                     # at lo the cost must rise going up, at hi going down
            wrong = held & (((x <= lo) & (g < -1e-12)) | ((x >= hi) & (g > 1e-12)))
            if not wrong.any():
                break
            held[np.flatnonzero(wrong)[np.argmax(np.abs(g[wrong]))]] = False
        M[:, j] = x
    for _ in range(50):
        before = M.copy()
        for v in range(n):
            M[v] = np.clip((B[v] - H[v] @ M + H[v, v] * M[v]) / H[v, v], lo, hi)
        if np.abs(M - before).max() < 1e-9:
            break
    return M


def params_matrix(preset: Preset | dict) -> np.ndarray:
    """(classes, parameters): each phone class's dominance parameters."""
    cl = as_preset(preset).dominance.classes
    return np.array([[getattr(cl[c], p) for p in PARAMS] for c in CLASSES], float)


def viseme_curves(clip: Prepared, preset: dict, vset, fps: float) -> np.ndarray:
    """(frames, visemes): the curves the engine makes for a prepared clip
    (the full synthesis path), on the clip's model frames."""
    al = copy.copy(clip.alignment)
    if clip.duration is not None:
        al.duration = clip.duration
    elif len(clip.times):
        al.duration = float(clip.times[-1])
    _w, _times, out = curves(al, clip.pitch, clip.intensity, clip.stats, vset, as_preset(preset), "dominance", fps)
    res = np.zeros((len(clip.times), out.shape[1]))
    n = min(len(out), len(clip.times))
    res[:n] = out[:n]
    return res


def synthesise(clip: Prepared, preset: dict, vset, channels: list[str], fps: float,
               mp: dict[str, dict[str, float]]) -> np.ndarray:
    """Tracks the engine makes for a prepared clip (the full synthesis path)."""
    out = viseme_curves(clip, preset, vset, fps)
    times = clip.times
    names, values = mapping.shape_key_curves(out, vset.visemes, mp)
    res = np.zeros((len(clip.times), len(channels)))
    n = min(len(times), len(clip.times))
    for j, c in enumerate(channels):
        if c in names:
            res[:n, j] = values[:n, names.index(c)]
    return res
