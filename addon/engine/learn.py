"""Learn an emotion preset from example animation (the second paper, 5.2-5.3).

Input: clips of one character speaking in one emotion, each with its audio,
its phoneme timings (from the aligner or an imported alignment) and the
measured tracks: shape-key values per frame, hand-keyed in Blender or
captured (ARKit CSV, see :mod:`.capture`).

Model: the one the engine synthesises with.  Each viseme event i of the
clip has a dominance function D_i(t) with its class's (alpha, theta, phi, c)
and the engine's plateau, and a target: its weight w_i (equations 1-2) times
the viseme's pose.  The predicted tracks are

    Y(t) = smooth( sum_i D_i(t) w_i e_{v_i} / sum_i D_i(t) ) @ M

where M (visemes x channels) holds each viseme's pose, times the rest
envelope of the pauses (:mod:`.pauses`) and with closure visemes capped on
vowels as the engine caps them (:func:`.coarticulation.closure_caps`).  The
frames around /p b m f v/, which the engine's closure step rewrites, are
left out of the fit.  As in the paper the
poses live in a PCA basis of the training tracks: M = A P^T with P the
components keeping ``variance`` (default 99 %) of the tracks' energy.

Fit: Levenberg-Marquardt on the dominance parameters in log space (bounds
keep every alpha, theta, phi positive and finite, c in [0.5, 2]), with the
analytic Jacobian, while the poses A, linear in the model, are solved
exactly at every step (variable projection).  The vowels' alpha stays at the
base preset's value: only ratios of alphas change the blend.  A share of the
clips is held out; training stops when the held-out error has not fallen for
``patience`` steps, and the parameters with the lowest held-out error win.

Output: a preset in the built-in format (the base preset of the same
emotion, with the fitted dominance parameters and a ``learned`` section with
the viseme set and poses), and a report: per-channel RMSE and variance
explained on training and held-out clips, for the learned preset and for the
built-in one, both through the engine's full synthesis path.
"""

from __future__ import annotations

import copy
import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from . import coarticulation, mapping, pauses, presets, prosody, visemes
from .align import Alignment
from .audio import Audio
from .errors import LipSyncError
from .phonemes import CLASSES

#: How far (s) around a closure the closure step rewrites the blend.
CLOSURE_REACH = 0.03

PARAMS = ("alpha", "theta", "phi", "c")
#: Bounds of the fitted parameters (the log of these bounds the search).
BOUNDS = {"alpha": (0.02, 50.0), "theta": (1.0, 250.0), "phi": (1.0, 250.0), "c": (0.5, 2.0)}
REFERENCE_CLASS = "vowel"       # its alpha is held: the blend depends on alpha ratios only


@dataclass
class TrainingClip:
    """One example: audio, phoneme timings and measured tracks."""

    name: str
    audio: Audio
    alignment: Alignment
    times: np.ndarray            # track sample times, s from the audio's start
    tracks: np.ndarray           # (samples, channels)
    channels: list[str]

    def __post_init__(self):
        if self.tracks.ndim != 2 or self.tracks.shape[0] != len(self.times):
            raise LipSyncError(f"{self.name}: {len(self.times)} times but {self.tracks.shape[0]} rows of tracks")
        if self.tracks.shape[1] != len(self.channels):
            raise LipSyncError(f"{self.name}: {self.tracks.shape[1]} track columns but {len(self.channels)} names")
        cover = self.times[-1] - self.times[0]
        if abs(cover - self.audio.duration) > max(0.5, 0.1 * self.audio.duration):
            raise LipSyncError(f"{self.name}: the tracks cover {cover:.2f} s but the audio lasts "
                               f"{self.audio.duration:.2f} s; do they belong together?")


@dataclass
class _Prepared:
    name: str
    times: np.ndarray            # model frames
    y: np.ndarray                # (frames, channels) measured, resampled
    centres: np.ndarray
    half: np.ndarray
    cls: np.ndarray              # class index per segment
    targets: np.ndarray          # (segments, visemes) w_i e_{v_i}
    alignment: Alignment = None
    pitch: np.ndarray = None
    intensity: np.ndarray = None
    stats: object = None
    rest: np.ndarray = None      # per frame: 0 where a pause forces the rest pose (pauses.rest_envelope)
    caps: dict = None            # closure viseme -> (vowel frames, cap): coarticulation.closure_caps
    fit: np.ndarray = None       # per frame: 1 if the blend is fitted there, 0 where closures rewrite it


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
        preset["learned"]["report"] = report_path.name
        presets.save(preset, path)
        report_path.write_text(json.dumps(self.report, indent=1) + "\n", encoding="utf-8")
        return path, report_path


def _prepare(clip: TrainingClip, vset, preset: dict, fps: float, channels: list[str]) -> _Prepared:
    from .pipeline import frame_times, phoneme_weights, rest_target

    snd, al = clip.audio, clip.alignment
    tracks = prosody.analyse(snd)
    wp = preset["weights"]
    pr = tuple(wp["pitch_range"]) if isinstance(wp["pitch_range"], list) else wp["pitch_range"]
    stats = prosody.clip_stats(tracks, wp["intensity_floor_db"], pr)
    pitch, inten = prosody.phoneme_means(tracks, [(p.start, p.end) for p in al.phones], stats)
    w = phoneme_weights(al, pitch, inten, stats, vset, preset)
    spans = [(p.phone, p.start, p.end) for p in al.phones]
    events = coarticulation.build_events(spans, w, vset, preset["rules"]["diphthong_split"])
    rest_i, rest_w = rest_target(vset, preset)
    duration = max(al.duration, snd.duration)
    segs = coarticulation.segments_with_silence(events, duration, rest_i, rest_w)
    times = frame_times(duration, fps)
    order = [clip.channels.index(c) for c in channels]
    y = np.empty((len(times), len(channels)))
    for j, k in enumerate(order):
        y[:, j] = np.interp(times, clip.times, clip.tracks[:, k])
    targets = np.zeros((len(segs), len(vset.visemes)))
    for i, s in enumerate(segs):
        if s.viseme >= 0:
            targets[i, s.viseme] = s.weight
    cfg = pauses.settings()["rest"]
    rest = pauses.rest_envelope(times, pauses.gaps([(p.start, p.end) for p in al.phones], duration,
                                                   cfg["min_pause"]), cfg["ramp"], duration)
    # The closure step rewrites the frames around every /p b m f v/: the blend is not fitted there.
    fit = np.ones(len(times))
    for ev in events:
        if ev.cls in coarticulation.CLOSURE_CLASSES:
            lo, hi = np.searchsorted(times, [ev.start - CLOSURE_REACH, ev.end + CLOSURE_REACH])
            fit[lo:hi] = 0.0
    return _Prepared(clip.name, times, y, np.array([s.centre for s in segs]),
                     preset["dominance"]["plateau"] * np.array([(s.end - s.start) / 2 for s in segs]),
                     np.array([CLASSES.index(s.cls) for s in segs]), targets, al, pitch, inten, stats, rest,
                     coarticulation.closure_caps(times, events), fit)


class _Model:
    """The dominance blend of one set of clips, and its derivatives."""

    def __init__(self, clips: list[_Prepared], fps: float, sigma: float, free: list[tuple[int, int]]):
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
            Cs = coarticulation.smooth(C, self.fps, self.sigma) * c.rest[:, None]
            bound = []   # (frames, viseme) where a closure cap holds the curve: no derivative there
            for v, (frames, cap) in (c.caps or {}).items():
                hit = frames[Cs[frames, v] > cap]
                Cs[frames, v] = np.minimum(Cs[frames, v], cap)
                bound.append((hit, v))
            out.append(Cs * c.fit[:, None])
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
                dCs = coarticulation.smooth(dC, self.fps, self.sigma) * c.rest[:, None]
                for hit, v in bound:
                    dCs[hit, v] = 0.0
                cj.append(dCs * c.fit[:, None])
            jacs.append(cj)
        return out, jacs


def _solve_poses(blends, zs, ridge, prior):
    """Poses A minimising sum ||C A - Z||^2 + lam ||A - prior||^2, with lam
    ``ridge`` times the mean of diag(C^T C): a viseme the clips barely show
    stays near the viseme set's own pose instead of fitting the noise."""
    CtC = sum(C.T @ C for C in blends)
    CtZ = sum(C.T @ Z for C, Z in zip(blends, zs))
    n = CtC.shape[0]
    lam = ridge * max(float(np.trace(CtC)) / n, 1e-12)
    return np.linalg.solve(CtC + lam * np.eye(n), CtZ + lam * prior)


def _params_matrix(preset: dict) -> np.ndarray:
    cl = preset["dominance"]["classes"]
    return np.array([[cl[c][p] for p in PARAMS] for c in CLASSES], float)


def _rmse_report(pred: list[np.ndarray], meas: list[np.ndarray], channels: list[str]) -> dict:
    Y = np.concatenate(meas)
    E = np.concatenate(pred) - Y
    sst = ((Y - Y.mean(axis=0)) ** 2).sum()
    return {"rmse": float(np.sqrt((E ** 2).mean())),
            "variance_explained": float(1.0 - (E ** 2).sum() / sst) if sst > 0 else None,
            "rmse_per_channel": {c: round(float(np.sqrt((E[:, j] ** 2).mean())), 5) for j, c in enumerate(channels)}}


def synthesise(clip: _Prepared, preset: dict, vset, channels: list[str], fps: float,
               mp: dict[str, dict[str, float]]) -> np.ndarray:
    """Tracks the engine makes for a prepared clip (the full synthesis path)."""
    from .pipeline import curves

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


def split_holdout(n: int, share: float, seed: int) -> tuple[list[int], list[int]]:
    """Indices of training and held-out clips (at least one of each when n >= 2)."""
    if n < 2:
        raise LipSyncError("learning needs at least two clips: one to train on and one to check the result")
    k = min(n - 1, max(1, int(round(share * n))))
    order = np.random.default_rng(seed).permutation(n)
    return sorted(order[k:].tolist()), sorted(order[:k].tolist())


def learn(clips: list[TrainingClip], *, emotion: str | dict = "neutral", viseme_set: str = "arkit",
          name: str = "learned", holdout: float = 0.2, variance: float = 0.99, fps: float = 30.0,
          max_iter: int = 60, patience: int = 5, seed: int = 0, ridge: float = 1e-3,
          heldout: list[int] | None = None,
          progress: Callable[[str, float], None] | None = None) -> Learned:
    """Fit a preset to ``clips`` (see the module docstring).

    ``heldout`` picks the held-out clips by index; otherwise a ``holdout``
    share of them is drawn with ``seed``.
    """
    def report(step, frac):
        if progress:
            progress(step, frac)

    t_start = time.perf_counter()
    base = presets.resolve(dict(emotion), "preset") if isinstance(emotion, dict) else presets.load(emotion)
    if base.get("learned"):
        raise LipSyncError("start from a built-in or hand-made preset, not a learned one")
    vset = visemes.load(viseme_set)
    channels = list(clips[0].channels) if clips else []
    for c in clips[1:]:
        missing = sorted(set(channels) - set(c.channels))
        if missing:
            raise LipSyncError(f"{c.name} lacks the tracks {', '.join(missing[:5])} that {clips[0].name} has")
    if heldout is not None:
        hold_i = sorted(set(heldout))
        train_i = [i for i in range(len(clips)) if i not in hold_i]
        if not hold_i or not train_i or hold_i[-1] >= len(clips):
            raise LipSyncError("the held-out clips must be some, not all, of the clips")
    else:
        train_i, hold_i = split_holdout(len(clips), holdout, seed)
    report("prepare", 0.0)
    prepared = []
    for k, c in enumerate(clips):
        prepared.append(_prepare(c, vset, base, fps, channels))
        report("prepare", (k + 1) / len(clips))
    train = [prepared[i] for i in train_i]
    hold = [prepared[i] for i in hold_i]

    # PCA of the training tracks (uncentred: the model has no offset, silence is the basis pose).
    Y = np.concatenate([c.y for c in train])
    _u, s, vt = np.linalg.svd(Y, full_matrices=False)
    energy = np.cumsum(s ** 2) / max((s ** 2).sum(), 1e-300)
    K = int(np.searchsorted(energy, variance) + 1)
    K = min(K, len(s))
    P = vt[:K].T                                                   # (channels, K)
    z_train = [(c.y @ P) * c.fit[:, None] for c in train]
    z_hold = [(c.y @ P) * c.fit[:, None] for c in hold]

    base_mp = mapping.auto_map(vset, channels)
    M0 = np.zeros((len(vset.visemes), len(channels)))
    for v, mix in base_mp.items():
        for ch, w in mix.items():
            M0[vset.index(v), channels.index(ch)] = w
    prior = M0 @ P

    present = sorted({int(k) for c in train for k in np.unique(c.cls)})
    free = [(k, p) for k in present for p in range(4)
            if not (CLASSES[k] == REFERENCE_CLASS and p == 0)]
    lo = np.array([np.log(BOUNDS[PARAMS[p]][0]) for _k, p in free])
    hi = np.array([np.log(BOUNDS[PARAMS[p]][1]) for _k, p in free])
    P0 = _params_matrix(base)
    q = np.clip(np.array([np.log(P0[k, p]) for k, p in free]), lo, hi)
    sigma = base["smoothing"]
    m_train = _Model(train, fps, sigma, free)
    m_hold = _Model(hold, fps, sigma, free)

    def params_of(qv):
        Pm = P0.copy()
        for (k, p), v in zip(free, qv):
            Pm[k, p] = np.exp(v)
        return Pm

    def cost(model, zs, Pm, A):
        bl, _ = model.blend(Pm, False)
        return sum(float(((b @ A - z) ** 2).sum()) for b, z in zip(bl, zs)), bl

    bl, jac = m_train.blend(params_of(q), True)
    A = _solve_poses(bl, z_train, ridge, prior)
    cur = sum(float(((b @ A - z) ** 2).sum()) for b, z in zip(bl, z_train))
    n_hold = sum(z.size for z in z_hold)
    best = (cost(m_hold, z_hold, params_of(q), A)[0], q.copy(), A.copy(), 0)
    history = [{"iteration": 0, "train_rmse": float(np.sqrt(cur / sum(z.size for z in z_train))),
                "heldout_rmse": float(np.sqrt(best[0] / n_hold))}]
    lam, since_best = 1e-2, 0
    for it in range(1, max_iter + 1):
        # Gauss-Newton system for the residual r = C A - Z in q.
        JtJ = np.zeros((len(free), len(free)))
        Jtr = np.zeros(len(free))
        for b, cj, z in zip(bl, jac, z_train):
            r = (b @ A - z).ravel()
            cols = [np.zeros(r.size) if g is None else (g @ A).ravel() for g in cj]
            J = np.stack(cols, axis=1)
            JtJ += J.T @ J
            Jtr += J.T @ r
        accepted = False
        for _try in range(10):
            H = JtJ + lam * np.diag(np.diag(JtJ) + 1e-9)
            step = -np.linalg.solve(H, Jtr)
            q_new = np.clip(q + step, lo, hi)
            bl_new, jac_new = m_train.blend(params_of(q_new), True)
            A_new = _solve_poses(bl_new, z_train, ridge, prior)
            new = sum(float(((b @ A_new - z) ** 2).sum()) for b, z in zip(bl_new, z_train))
            if new < cur:
                q, A, bl, jac, cur = q_new, A_new, bl_new, jac_new, new
                lam = max(lam / 3, 1e-7)
                accepted = True
                break
            lam *= 4
        held = cost(m_hold, z_hold, params_of(q), A)[0]
        history.append({"iteration": it, "train_rmse": float(np.sqrt(cur / sum(z.size for z in z_train))),
                        "heldout_rmse": float(np.sqrt(held / n_hold))})
        report("fit", it / max_iter)
        if held < best[0] - 1e-12:
            best, since_best = (held, q.copy(), A.copy(), it), 0
        else:
            since_best += 1
        if since_best >= patience or not accepted:
            break
    _held, q, A, best_it = best

    # The preset: the base, with the fitted dominance parameters and poses.
    Pm = params_of(q)
    out = copy.deepcopy(base)
    out["name"] = name
    out["description"] = (f"Learned from {len(train)} example clips ({base.get('name', 'preset')} as the base); "
                          f"see the training report")
    for k, c in enumerate(CLASSES):
        for p, pn in enumerate(PARAMS):
            out["dominance"]["classes"][c][pn] = round(float(Pm[k, p]), 5)
    out["gain"] = 1.0
    M = A @ P.T
    clipped = int(np.sum(np.abs(M) > 3.0))
    M = np.clip(M, -3.0, 3.0)   # the range a preset allows; reported below
    targets = {}
    for i, v in enumerate(vset.visemes):
        mix = {ch: round(float(M[i, j]), 4) for j, ch in enumerate(channels) if abs(M[i, j]) >= 1e-3}
        if mix:
            targets[v] = mix
    out["learned"] = {"viseme_set": vset.name, "targets": targets}
    out = presets.validate(out, name)

    # Honest numbers: both presets through the engine's own synthesis path.
    learned_set = visemes.with_targets(vset, targets)
    learned_mp = {v: mix for v, mix in targets.items()}

    def evaluate(group, preset, vs, mp):
        pred = [synthesise(c, preset, vs, channels, fps, mp) for c in group]
        return _rmse_report(pred, [c.y for c in group], channels)

    report("evaluate", 0.0)
    result = {
        "name": name, "base_preset": base.get("name"), "viseme_set": vset.name, "fps": fps,
        "channels": channels,
        "clips": {"train": [c.name for c in train], "heldout": [c.name for c in hold]},
        "pca": {"components": K, "variance_kept": float(energy[K - 1]), "target": variance},
        "poses_clipped": clipped,
        "fit": {"free_parameters": len(free) + A.size, "iterations": len(history) - 1, "best_iteration": best_it,
                "stopped": "held-out error stopped falling" if since_best >= patience else
                ("no further improvement" if len(history) - 1 < max_iter else "iteration limit"),
                "seconds": round(time.perf_counter() - t_start, 3), "history": history},
        "learned": {"train": evaluate(train, out, learned_set, learned_mp),
                    "heldout": evaluate(hold, out, learned_set, learned_mp)},
        "builtin": {"train": evaluate(train, base, vset, base_mp),
                    "heldout": evaluate(hold, base, vset, base_mp)},
    }
    lh, bh = result["learned"]["heldout"]["rmse"], result["builtin"]["heldout"]["rmse"]
    result["better_than_builtin"] = bool(lh < bh)
    result["better_channels"] = sorted(
        c for c in channels
        if result["learned"]["heldout"]["rmse_per_channel"][c] < result["builtin"]["heldout"]["rmse_per_channel"][c])
    result["fit"]["seconds"] = round(time.perf_counter() - t_start, 3)
    report("done", 1.0)
    return Learned(out, result, history)


def load_clip(audio_path: str | os.PathLike, tracks_path: str | os.PathLike | None = None,
              transcript: str | None = None, alignment_path: str | os.PathLike | None = None,
              capture_fps: float = 60.0, dictionary: str | None = None) -> TrainingClip:
    """A training clip from files: ``line.wav`` with ``line.csv`` (capture)
    and ``line.txt`` (transcript) or ``line.TextGrid`` (alignment) beside it,
    unless given."""
    from . import audio as audio_mod
    from .capture import read_capture_csv
    from .importers import read_alignment
    from .pipeline import align_audio
    from .pronounce import Lexicon
    from .text import read_text_file

    audio_path = Path(audio_path)
    stem = audio_path.with_suffix("")
    tracks_path = Path(tracks_path) if tracks_path else stem.with_suffix(".csv")
    snd = audio_mod.load(audio_path)
    times, values, channels = read_capture_csv(tracks_path, capture_fps)
    if alignment_path is None and transcript is None:
        grid = stem.with_suffix(".TextGrid")
        if grid.is_file():
            alignment_path = grid
        elif stem.with_suffix(".txt").is_file():
            transcript, _notes = read_text_file(stem.with_suffix(".txt"))
        else:
            raise LipSyncError(f"{audio_path.name}: no transcript ({stem.name}.txt) or alignment "
                               f"({stem.name}.TextGrid) beside it")
    if alignment_path is not None:
        al = read_alignment(alignment_path, audio_duration=snd.duration)
        al.duration = max(al.duration, snd.duration)
    else:
        al = align_audio(snd, transcript, Lexicon.with_user_file(dictionary))
    return TrainingClip(audio_path.stem, snd, al, times, values, channels)
