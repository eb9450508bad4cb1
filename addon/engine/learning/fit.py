"""Fitting a preset to example clips (the second paper, 5.2-5.3).

Input: clips of one character speaking in one emotion, each with its audio,
its phoneme timings (from the aligner or an imported alignment) and the
measured tracks: shape-key values per frame (hand-keyed in Blender or an
ARKit capture), or articulatory proxies / viseme tracks from articulography
or landmark tracking (see :mod:`.proxies`).

Model: the one the engine synthesises with.  Each viseme event i of the
clip has a dominance function D_i(t) with its class's (alpha, theta, phi, c)
and the engine's plateau, and a target: its weight w_i (equations 1-2) times
the viseme's pose.  The predicted tracks are

    Y(t) = smooth( sum_i D_i(t) w_i e_{v_i} / sum_i D_i(t) ) @ M

For shape keys M (visemes x channels) holds each viseme's pose, learned: as
in the paper the poses live in a PCA basis of the training tracks, M = A P^T
with P the components keeping ``variance`` (default 99 %) of the tracks'
energy, and A is solved exactly at every step (variable projection).  The
poses written are then solved on every track with each value in [0, 1] and
a pull toward the starting poses as strong as ``pose_prior`` s of the viseme
shown in full (:func:`.model.bounded_poses`): the less the clips show a
viseme, the nearer it stays to its starting pose.  For
proxies and viseme tracks M is fixed (:func:`.proxies.poses`) and each track
has a gain and an offset solved the same way, so the fit is judged on the
shape and timing of the motion, not its units: the squared error left after
the best gain and offset is (1 - r^2) of the track's variance, r the
correlation.  Each proxy track counts alike, and frames inside /p b m/
count ``closure_weight`` times on ``lip_aperture``: a closure at the wrong
time is what a viewer sees first.

The capture's delay to the sound is estimated (:mod:`.delay`) with the
starting preset, then again with the fitted one, and the tracks are read
with it; the fit is repeated once at the new delay.

Fit: Levenberg-Marquardt on the dominance parameters in log space (bounds
keep every alpha, theta, phi positive and finite, c in [0.5, 2]), with the
analytic Jacobian, and a penalty ``regularisation`` * |q - q0|^2 pulling the
log-parameters q toward the starting preset's q0, so a few clips cannot
drag them far.  The vowels' alpha stays at the starting value: only ratios of
alphas change the blend.

Evaluation: with few clips (``max_folds`` or fewer) each clip is held out
in turn and predicted by a preset fitted to the others (leave-one-clip-out);
otherwise a share of the clips is held out, and training stops when their
error has not fallen for ``patience`` steps.  The report gives, per track
and per held-out clip, correlation, RMSE and peak-timing error for the
learned preset and the starting one (:mod:`.report`).  The preset written
takes from the fit only the parts (:mod:`.parts`: timing per group of
phoneme classes, poses per articulator) that the held-out check over every
fold supports without making any track worse (:mod:`.select`); the rest is
the starting preset's.  ``keep_learned`` takes every part.

The expression layer is fitted too when the capture carries its channels
(an ARKit capture's brows, cheeks, eyes and mouth corners):
:func:`..expression.fit` gives each action unit's strength, which the
learned preset carries (``expression``) and the report lists.
"""

from __future__ import annotations

import copy
import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from collections.abc import Callable

import numpy as np

from .. import expression, mapping, presets, visemes
from . import gestures_fit
from ..errors import LipSyncError
from ..language.phonemes import CLASSES
from . import delay as delay_mod
from . import parts as parts_mod
from . import proxies, report, select
from .data import Prepared, TrainingClip, prepare
from .model import BOUNDS, PARAMS, REFERENCE_CLASS, Model, bounded_poses, params_matrix, solve_poses

MAX_FOLDS = 8


@dataclass
class Learned:
    preset: dict
    report: dict
    history: list = field(default_factory=list)

    def save(self, path: str | os.PathLike) -> tuple[Path, Path]:
        """Write the preset and its report (``NAME.report.json``) beside it."""
        path = Path(path)
        report_path = path.with_name(path.stem + ".report.json")
        preset = copy.deepcopy(self.preset)
        if "learned" in preset:
            preset["learned"]["report"] = report_path.name
        presets.save(preset, path)
        report_path.write_text(json.dumps(self.report, indent=1) + "\n", encoding="utf-8")
        return path, report_path


def split_holdout(n: int, share: float, seed: int) -> tuple[list[int], list[int]]:
    """Indices of training and held-out clips (at least one of each when n >= 2)."""
    if n < 2:
        raise LipSyncError("learning needs at least two clips: one to train on and one to check the result")
    k = min(n - 1, max(1, int(round(share * n))))
    order = np.random.default_rng(seed).permutation(n)
    return sorted(order[k:].tolist()), sorted(order[:k].tolist())


@dataclass
class Setup:
    """What every fit of one call shares."""

    base: dict
    vset: object
    channels: list[str]
    fps: float
    calibrated: bool             # proxies / viseme tracks: fixed poses, gain and offset per track
    M0: np.ndarray               # (visemes, channels): fixed poses, or the prior of learned ones
    start_map: dict | None       # shape keys: the starting poses, viseme -> {channel: weight}
    P0: np.ndarray               # (classes, 4) the starting parameters
    ridge: float
    variance: float
    regularisation: float
    closure_weight: float
    delay: float | None          # None: estimate it
    gain0: float = 1.0           # the starting preset's gain (learned poses carry it: a learned preset's is 1)
    pose_prior: float = 0.0      # frames: how strongly poses are pulled toward the start (model.bounded_poses)


@dataclass
class Fit:
    Pm: np.ndarray               # (classes, 4) fitted parameters
    delay: float
    delay_score: float
    history: list
    best_iteration: int
    stopped: str
    free: int
    targets: dict | None = None  # learned poses (shape keys)
    M: np.ndarray | None = None  # the same, (visemes, channels)
    pca: dict | None = None
    clipped: int = 0             # pose values the [0, 1] range holds


class _Objective:
    """Normalised residuals of one set of clips at one delay, with the
    normal equations of the free log-parameters."""

    def __init__(self, setup: Setup, clips: list[Prepared], free, delay: float, basis=None):
        self.s, self.clips, self.free, self.P = setup, clips, free, basis
        self.model = Model(clips, setup.fps, setup.base["smoothing"], free, setup.base["closure"]["strength"])
        self.w = []
        ap = setup.channels.index("lip_aperture") if "lip_aperture" in setup.channels else None
        for c in clips:
            w = np.ones((len(c.times), len(setup.channels)))
            if setup.calibrated and ap is not None:
                w[c.closure, ap] = setup.closure_weight
            self.w.append(w)
        self.set_delay(delay)
        if setup.calibrated:
            W, Y = np.concatenate(self.w), np.concatenate(self.ys)
            mean = (W * Y).sum(axis=0) / W.sum(axis=0)
            ss = (W * (Y - mean) ** 2).sum(axis=0)
            self.scale = 1.0 / np.sqrt(len(setup.channels) * np.maximum(ss, 1e-12))   # per track
        else:
            Z = np.concatenate(self.ys)
            self.scale = 1.0 / np.sqrt(max(float(((Z - Z.mean(axis=0)) ** 2).sum()), 1e-12))
            self.prior = setup.gain0 * setup.M0 @ basis

    def set_delay(self, d: float) -> None:
        """Read the measured tracks at delay ``d`` (and their slope in d)."""
        h = 0.5 / self.s.fps
        self.delay = d
        self.ys, self.dys = [], []
        for c in self.clips:
            y, up, down = c.aligned(d), c.aligned(d + h), c.aligned(d - h)
            if self.P is not None:
                y, up, down = y @ self.P, up @ self.P, down @ self.P
            self.ys.append(y)
            self.dys.append((up - down) / (2 * h))
        self.zs = self.ys

    def solve(self, bl, fixed=None):
        """The linear part: poses A (shape keys) or (gain, offset) per track."""
        s = self.s
        if s.calibrated:
            if fixed is not None:
                return fixed
            return proxies.calibrate([b @ s.M0 for b in bl], self.ys, self.w)
        if fixed is not None:
            return fixed
        return solve_poses(bl, self.zs, s.ridge, self.prior)

    def residuals(self, b, k, lin):
        """Weighted residual (frames, columns) of clip k."""
        if self.s.calibrated:
            gain, offset = lin
            r = (b @ self.s.M0) * gain + offset - self.ys[k]
            return r * np.sqrt(self.w[k]) * self.scale
        return (b @ lin - self.zs[k]) * self.scale

    def predictions(self, Pm, lin) -> list[np.ndarray]:
        bl, _ = self.model.blend(Pm, False)
        if self.s.calibrated:
            gain, offset = lin
            return [(b @ self.s.M0) * gain + offset for b in bl]
        return [b @ lin @ self.P.T for b in bl]

    def cost(self, Pm, lin=None, want_jac=False, with_delay=False):
        """(cost, linear part, J^T J, J^T r) in the free log-parameters,
        and the delay last when ``with_delay``."""
        bl, jac = self.model.blend(Pm, want_jac)
        lin = self.solve(bl, lin)
        total = 0.0
        n = len(self.free) + (1 if with_delay else 0)
        JtJ, Jtr = np.zeros((n, n)), np.zeros(n)
        for k, b in enumerate(bl):
            r = self.residuals(b, k, lin)
            total += float((r ** 2).sum())
            if not want_jac:
                continue
            R = jac[k]                                    # (frames, free, visemes)
            if self.s.calibrated:
                gain, _off = lin
                Jq = np.einsum("fiv,vc->fci", R, self.s.M0) * (gain[None, :, None] * self.scale[None, :, None]
                                                               * np.sqrt(self.w[k])[:, :, None])
            else:
                Jq = np.einsum("fiv,vk->fki", R, lin) * self.scale
            cols = [Jq.reshape(r.size, -1)]
            if with_delay:
                dr = -self.dys[k] * self.scale
                cols.append((dr * np.sqrt(self.w[k]) if self.s.calibrated else dr).reshape(-1, 1))
            J = np.concatenate(cols, axis=1)
            JtJ += J.T @ J
            Jtr += J.T @ r.ravel()
        return total, lin, JtJ, Jtr


def _free(setup: Setup, clips: list[Prepared]):
    present = sorted({int(k) for c in clips for k in np.unique(c.cls)})
    free = [(k, p) for k in present for p in range(4) if not (CLASSES[k] == REFERENCE_CLASS and p == 0)]
    lo = np.array([np.log(BOUNDS[PARAMS[p]][0]) for _k, p in free])
    hi = np.array([np.log(BOUNDS[PARAMS[p]][1]) for _k, p in free])
    q0 = np.clip(np.array([np.log(setup.P0[k, p]) for k, p in free]), lo, hi)
    return free, lo, hi, q0


def _params(setup: Setup, free, qv) -> np.ndarray:
    Pm = setup.P0.copy()
    for (k, p), v in zip(free, qv):
        Pm[k, p] = np.exp(v)
    return Pm


def _lm(setup, obj: _Objective, valid: _Objective | None, free, lo, hi, q0, x, max_iter, patience, progress,
        with_delay: bool):
    """Levenberg-Marquardt from x (the free log-parameters, then the delay
    when ``with_delay``); returns (x, linear part, history, best iteration,
    why it stopped)."""
    mu = setup.regularisation
    n = len(free)
    reg = np.zeros(len(x))
    reg[:n] = mu

    def evaluate(xv, jac=True):
        if with_delay:
            obj.set_delay(float(xv[-1]))
        c, lv, JtJ, Jtr = obj.cost(_params(setup, free, xv[:n]), want_jac=jac, with_delay=with_delay)
        return c + mu * float(((xv[:n] - q0) ** 2).sum()), lv, JtJ, Jtr

    def held(xv, lv):
        if valid is None:
            return None
        if with_delay:
            valid.set_delay(float(xv[-1]))
        return valid.cost(_params(setup, free, xv[:n]), lv)[0]

    cur, lin, JtJ, Jtr = evaluate(x)
    best = (held(x, lin), x.copy(), lin, 0)
    history = [{"iteration": 0, "train_cost": cur, "heldout_cost": best[0]}]
    lam, since_best, stopped = 1e-2, 0, "iteration limit"
    for it in range(1, max_iter + 1):
        A = JtJ + np.diag(reg)
        g = Jtr + reg * (x - np.concatenate([q0, x[n:]]))
        accepted = False
        for _try in range(10):
            step = -np.linalg.solve(A + lam * np.diag(np.diag(A) + 1e-9), g)
            x_new = np.clip(x + step, lo, hi)
            new, lin_new, JtJ_new, Jtr_new = evaluate(x_new)
            if new < cur:
                gain = cur - new
                x, lin, JtJ, Jtr, cur = x_new, lin_new, JtJ_new, Jtr_new, new
                lam = max(lam / 3, 1e-7)
                accepted = True
                break
            lam *= 4
        h = held(x, lin)
        history.append({"iteration": it, "train_cost": cur, "heldout_cost": h}
                       | ({"delay_ms": round(1000 * float(x[-1]), 2)} if with_delay else {}))
        if progress:
            progress(it / max_iter)
        if valid is None:
            best = (None, x.copy(), lin, it) if accepted else best
        elif h < best[0] - 1e-12:
            best, since_best = (h, x.copy(), lin, it), 0
        else:
            since_best += 1
        if valid is not None and since_best >= patience:
            stopped = "held-out error stopped falling"
            break
        if not accepted or gain < 1e-4 * max(cur, 1e-12):
            stopped = "no further improvement"
            break
    return best[1], best[2], history, best[3], stopped


def fit(setup: Setup, train: list[Prepared], valid: list[Prepared] | None = None, *, max_iter: int = 60,
        patience: int = 5, progress: Callable[[float], None] | None = None) -> Fit:
    """Fit the dominance parameters (and the poses, for shape keys) to ``train``."""
    free, lo, hi, q0 = _free(setup, train)
    basis, pca = None, None
    if not setup.calibrated:
        Y = np.concatenate([c.y for c in train])
        _u, sv, vt = np.linalg.svd(Y, full_matrices=False)
        energy = np.cumsum(sv ** 2) / max((sv ** 2).sum(), 1e-300)
        K = min(int(np.searchsorted(energy, setup.variance) + 1), len(sv))
        basis = vt[:K].T
        pca = {"components": K, "variance_kept": float(energy[K - 1]), "target": setup.variance}

    def objective(clips, d):
        return _Objective(setup, clips, free, d, basis) if clips else None

    with_delay = setup.delay is None
    d, d_score = (0.0, None) if with_delay else (setup.delay, None)
    if with_delay:                      # start from the starting preset's own best delay
        o = objective(train, 0.0)
        _c, lin, _a, _b = o.cost(setup.P0)
        d, d_score = delay_mod.estimate(o.predictions(setup.P0, lin), train)
    obj, val = objective(train, d), objective(valid, d)
    x = np.concatenate([q0, [d]]) if with_delay else q0.copy()
    if with_delay:
        lo = np.concatenate([lo, [-delay_mod.MAX_DELAY]])
        hi = np.concatenate([hi, [delay_mod.MAX_DELAY]])
    x, lin, history, best_it, stopped = _lm(setup, obj, val, free, lo, hi, q0, x, max_iter, patience, progress,
                                            with_delay)
    q = x[:len(free)]
    Pm = _params(setup, free, q)
    if with_delay:
        d = float(x[-1])
        obj.set_delay(d)
        lin = obj.cost(Pm)[1]
        d_score = delay_mod.score(obj.predictions(Pm, lin), train, d)
    out = Fit(Pm, float(d), d_score, history, best_it, stopped, len(free) + (0 if setup.calibrated else lin.size))
    out.pca = pca
    if not setup.calibrated:
        # The poses on every track, each value in the [0, 1] a shape key shows, pulled toward the
        # starting poses as strongly as ``pose_prior`` frames of each viseme: a viseme the clips do not
        # show keeps its starting pose, one they show for long follows them.
        bl, _ = obj.model.blend(Pm, False)
        ys = [c.aligned(d) for c in train]
        prior = setup.gain0 * setup.M0
        M = bounded_poses(bl, ys, prior, setup.pose_prior)
        free_M = solve_poses(bl, ys, 1e-9, prior, setup.pose_prior)
        out.clipped = int(np.sum((free_M < -1e-3) | (free_M > 1.0 + 1e-3)))
        out.M = M
        targets = {}
        for i, v in enumerate(setup.vset.visemes):
            mix = {ch: round(float(M[i, j]), 4) for j, ch in enumerate(setup.channels) if abs(M[i, j]) >= 1e-3}
            if mix:
                targets[v] = mix
        out.targets = targets
    return out


def make_preset(setup: Setup, f: Fit, name: str, n_clips: int, timing: dict | None = None,
                poses=None) -> dict:
    """The starting preset with the fitted parts: the dominance parameters
    of the ``timing`` parts, each moved by its share from the start toward
    the fit (:func:`.select.shift`), and the poses of the ``poses`` parts
    (:mod:`.parts`; None: every part, all the way)."""
    out = copy.deepcopy(setup.base)
    out["name"] = name
    P = f.Pm if timing is None else select.shift(setup.P0, f.Pm, timing)
    for k, c in enumerate(CLASSES):
        for p, pn in enumerate(PARAMS):
            out["dominance"]["classes"][c][pn] = round(float(P[k, p]), 5)
    learned_poses = f.M is not None and (poses is None or len(poses) > 0)
    if learned_poses:
        M = f.M if poses is None else setup.gain0 * setup.M0
        if poses is not None:
            M = M.copy()
            for part in poses:
                M[:, list(part.cells)] = f.M[:, list(part.cells)]
        M = np.clip(M, 0.0, 1.0)
        targets = {}
        for i, v in enumerate(setup.vset.visemes):
            mix = {ch: round(float(M[i, j]), 4) for j, ch in enumerate(setup.channels) if abs(M[i, j]) >= 1e-3}
            if mix:
                targets[v] = mix
        out["gain"] = 1.0
        out["learned"] = {"viseme_set": setup.vset.name, "targets": targets}
    what = "every part" if timing is None and poses is None else ", ".join(_learned_parts(timing, poses))
    out["description"] = (f"Learned from {n_clips} example clips ({setup.base.get('name', 'preset')} as the "
                          f"base): learned {what}; the rest kept from the base; see the training report")
    return presets.validate(out, name)


def _learned_parts(timing: dict | None, poses) -> list[str]:
    """The parts learned, in words: ``vowels onset/offset (50 %)``, ``jaw poses``."""
    out = [p.name if t >= 1.0 else f"{p.name} ({100 * t:.0f} %)"
           for p, t in sorted((timing or {}).items(), key=lambda x: x[0].name)]
    return out + sorted(p.name for p in poses or ())


def _start_map(vset, channels: list[str], given: dict | None) -> dict[str, dict[str, float]]:
    """The starting poses on the tracks (see :func:`learn`)."""
    if given is None:
        return mapping.auto_map(vset, channels)
    out = {}
    for v, mix in given.items():
        if v not in vset.visemes:
            raise LipSyncError(f"the starting mapping names {v!r}, which is not a viseme of the {vset.name!r} set")
        kept = {ch: float(w) for ch, w in mix.items() if ch in channels}
        if kept:
            out[v] = kept
    return out


def learn(clips: list[TrainingClip], *, emotion: str | dict | presets.Preset = "neutral",
          viseme_set: str = "arkit", name: str = "learned", holdout: float = 0.2, variance: float = 0.99,
          fps: float = 30.0,
          max_iter: int = 60, patience: int = 5, seed: int = 0, ridge: float = 1e-3,
          heldout: list[int] | None = None, cross_validate: bool | None = None, max_folds: int = MAX_FOLDS,
          regularisation: float = 1e-5, closure_weight: float = 3.0, delay: float | None = None,
          keep_learned: bool = False, start_map: dict[str, dict[str, float]] | None = None, pose_prior: float = 0.02,
          progress: Callable[[str, float], None] | None = None) -> Learned:
    """Fit a preset to ``clips`` (see the module docstring).

    ``start_map``: for shape-key tracks, the poses the starting preset
    shows, viseme -> {track: weight} (a rig's own mapping; keys that are not
    tracks are left out); by default the viseme set's own names and mixes
    found among the tracks (:func:`..mapping.auto_map`), every track a
    candidate whatever its column.  ``heldout`` picks the held-out clips by
    index; otherwise, with ``max_folds`` clips or fewer (or
    ``cross_validate``), every clip is held out in turn, else a ``holdout``
    share of them is drawn with ``seed``.
    ``delay`` fixes the capture's delay to the sound (s) instead of
    estimating it.  ``pose_prior`` (s): how strongly learned poses are
    pulled toward the starting ones, as that much of a viseme shown in full.
    ``keep_learned`` takes every part of the fit; otherwise the held-out
    check picks them (:mod:`.select`).
    """
    def tell(step, frac):
        if progress:
            progress(step, frac)

    t_start = time.perf_counter()
    if isinstance(emotion, presets.Preset):
        base = emotion.to_dict()
    else:
        base = presets.resolve(dict(emotion), "preset") if isinstance(emotion, dict) else presets.read(emotion)
    if base.get("learned"):
        raise LipSyncError("start from a built-in or hand-made preset, not a learned one")
    vset = visemes.load(viseme_set)
    if len(clips) < 2:
        raise LipSyncError("learning needs at least two clips: one to train on and one to check the result")
    channels = list(clips[0].channels)
    for c in clips[1:]:
        missing = sorted(set(channels) - set(c.channels))
        if missing:
            raise LipSyncError(f"{c.name} lacks the tracks {', '.join(missing[:5])} that {clips[0].name} has")
    calibrated = proxies.is_calibrated(channels)
    if calibrated:
        M0 = proxies.poses(vset, channels)
        base_mp = None
    else:
        base_mp = _start_map(vset, channels, start_map)
        M0 = np.zeros((len(vset.visemes), len(channels)))
        for v, mix in base_mp.items():
            for ch, w in mix.items():
                M0[vset.index(v), channels.index(ch)] = w
    setup = Setup(base, vset, channels, fps, calibrated, M0, base_mp, params_matrix(base), ridge, variance,
                  regularisation, closure_weight, delay, float(base.get("gain", 1.0)), pose_prior * fps)

    if heldout is not None:
        hold_i = sorted(set(heldout))
        train_i = [i for i in range(len(clips)) if i not in hold_i]
        if not hold_i or not train_i or hold_i[-1] >= len(clips):
            raise LipSyncError("the held-out clips must be some, not all, of the clips")
        folds = [(train_i, hold_i)]
        scheme = "held-out clips"
    elif cross_validate or (cross_validate is None and len(clips) <= max_folds):
        folds = [([j for j in range(len(clips)) if j != i], [i]) for i in range(len(clips))]
        scheme = "leave-one-clip-out"
    else:
        folds = [split_holdout(len(clips), holdout, seed)]
        scheme = "held-out clips"
    tell("prepare", 0.0)
    prepared = []
    for k, c in enumerate(clips):
        prepared.append(prepare(c, vset, base, fps, channels))
        tell("prepare", (k + 1) / len(clips))

    single = scheme == "held-out clips"
    n_fits = len(folds) + (0 if single else 1)
    fits = []
    for n, (tr, ho) in enumerate(folds):
        train, hold = [prepared[i] for i in tr], [prepared[i] for i in ho]
        f = fit(setup, train, hold if single else None, max_iter=max_iter, patience=patience,
                progress=lambda x, n=n: tell("fit", (n + x) / n_fits))
        fits.append((tr, ho, f))
    if single:
        tr, _ho, final = fits[0]
    else:
        tr = list(range(len(clips)))
        final = fit(setup, prepared, None, max_iter=max_iter, patience=patience,
                    progress=lambda x: tell("fit", (len(folds) + x) / n_fits))

    tell("evaluate", 0.0)
    timing_all = parts_mod.timing_parts(_free(setup, [prepared[i] for i in tr])[0])
    poses_all = [] if calibrated else parts_mod.pose_parts(channels)
    if keep_learned:
        timing, poses, found = {p: 1.0 for p in timing_all}, frozenset(poses_all), None
    else:
        timing, poses, found = select.Judge(setup, prepared, fits, timing_all, poses_all).choose()
    results = [(tr_f, ho_f, f, make_preset(setup, f, name, len(tr_f), timing, poses)) for tr_f, ho_f, f in fits]
    preset = make_preset(setup, final, name, len(tr), timing, poses)
    result = report.build(setup, prepared, results, final, preset, scheme, tr)
    result.update({"name": name, "base_preset": base.get("name")})
    learned_parts = _learned_parts(timing, poses)
    taken = {p.name for p in timing} | {p.name for p in poses}
    result["parts"] = {"learned": learned_parts,
                       "kept": sorted(p.name for p in timing_all + poses_all if p.name not in taken),
                       "shares": {p.name: t for p, t in timing.items()}, "check": found}
    kept = "learned" if learned_parts else "start"
    result["kept"] = kept
    if kept == "start":
        preset = copy.deepcopy(base)
        preset["name"] = name
        preset["description"] = (f"The starting preset {base.get('name', '')!r}, kept: no part learned from "
                                 f"{len(tr)} clips did better on the held-out clips (see the training report)")
        preset = presets.validate(preset, name)
    # The expression layer, from the capture's brow, eye, cheek and mouth-corner channels.
    face = expression.fit([(c.times, c.aligned(final.delay), [(p.phone, p.start, p.end) for p in c.alignment.phones],
                            c.pitch) for c in prepared], channels, fps)
    result["expression"] = face
    if face and kept == "learned":
        preset["expression"] = {u: v["strength"] for u, v in face.items()}
        preset = presets.validate(preset, name)
    # The gestures (blinks, gaze, head) as the capture shows them, whatever the mouth's fit kept.
    moving = gestures_fit.measure([(c.times - final.delay, c.tracks, c.alignment, c.head) for c in clips], channels)
    result["gestures"] = moving
    if moving["values"]:
        preset["gestures"] = {**preset.get("gestures", {}), **moving["values"]}
        preset = presets.validate(preset, name)
    result["fit"]["seconds"] = round(time.perf_counter() - t_start, 3)
    tell("done", 1.0)
    return Learned(preset, result, final.history)
