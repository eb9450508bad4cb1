"""Arousal from the voice alone: how calm (-1) or excited (+1) a line sounds.

Equations 1 and 2 weigh each phoneme against the clip's own pitch and
intensity, so a shouted and a whispered reading of a line give the same
relative weights.  This module measures the clip's overall arousal on an
absolute scale, without a transcript, so the weights can follow it across
lines (``weights.follow_voice`` in a preset).

Features (all independent of the recording level, since a gain change
moves every frame's dB by the same amount):

``pitch``     median F0 of the voiced frames, semitones re 100 Hz.
``centroid``  median spectral centroid (50-5000 Hz) of the speech frames,
              in octaves re 1 kHz: raised vocal effort tilts the spectrum up.
``dynamics``  mean absolute change of intensity between consecutive speech
              frames, dB per 10 ms: excited speech is more punctuated.
``voiced``    share of the speech frames that are voiced.

Speech frames are those within ``speech_db`` of the clip's loudest frame.
The model (``data/arousal.json``) standardises each feature with a centre
and a scale, sums them with weights and a bias, and squashes the sum with
``tanh`` into [-1, 1].  Its constants were fitted by ridge regression on
labelled clips (see ``bench/arousal.py``, which also measures the
estimator under cross-validation); a studio can refit them and point
``LIPSYNC_AROUSAL_MODEL`` at its own file.

When a transcript has been aligned, the speaking rate (phonemes per second
of speech) is reported with the features; the model only uses it if its
file gives it a weight (the shipped one does not: the labelled clips have no
transcripts).

The track over time applies the same model to windows of ``window`` seconds
every ``hop`` seconds (features a window lacks, such as pitch in an
unvoiced stretch, take the clip's value) and smooths the result.
"""

from __future__ import annotations

import copy
import os
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np

from . import datafile, prosody, smoothing
from .audio import Audio
from .errors import LipSyncError

DATA = Path(__file__).parent / "data" / "arousal.json"
#: Names an arousal model file of the studio's own, used instead of :data:`DATA`.
MODEL_ENV = "LIPSYNC_AROUSAL_MODEL"
FEATURES = ("pitch", "centroid", "dynamics", "voiced", "rate")
STEP = 0.01  # s, frame step of every feature track


@dataclass
class Estimate:
    """A clip's arousal, its features and the smooth track over time."""

    value: float                      # in [-1, 1]
    features: dict[str, float]
    times: np.ndarray = field(default_factory=lambda: np.zeros(0))   # s
    track: np.ndarray = field(default_factory=lambda: np.zeros(0))   # in [-1, 1]

    def at(self, t) -> np.ndarray:
        """The track at time(s) ``t`` (the clip value when there is no track)."""
        t = np.asarray(t, dtype=float)
        if len(self.times) == 0:
            return np.full(t.shape, self.value)
        return np.interp(t, self.times, self.track)

    def to_dict(self, step: float = 0.1) -> dict:
        """JSON form: the value, the features and the track every ``step`` s."""
        if len(self.times):
            t = np.arange(0.0, self.times[-1] + step / 2, step)
            tr = self.at(t)
        else:
            t, tr = np.zeros(0), np.zeros(0)
        return {"value": round(float(self.value), 4),
                "features": {k: (None if v is None or not np.isfinite(v) else round(float(v), 4))
                             for k, v in self.features.items()},
                "track": {"time": [round(float(x), 3) for x in t], "value": [round(float(x), 4) for x in tr]}}


@dataclass
class Frames:
    """Per-frame (10 ms) measurements the features are summarised from."""

    times: np.ndarray
    pitch_st: np.ndarray     # semitones re 100 Hz, NaN unvoiced
    intensity: np.ndarray    # dB
    centroid: np.ndarray     # octaves re 1 kHz, NaN for silent frames
    speech: np.ndarray       # bool


def load_model(path: str | os.PathLike | None = None) -> dict:
    """The model's constants: ``path``, else the file ``$LIPSYNC_AROUSAL_MODEL`` names, else the built-in one.

    A file is read and checked once while it is unchanged (a run asks for the
    model for every preset it renders); each call gets its own copy."""
    from_env = path is None and os.environ.get(MODEL_ENV)
    path = Path(path or from_env or DATA)
    if not path.is_file():
        named = f" named by {MODEL_ENV}" if from_env else ""
        problem = "is a folder, not a file" if path.is_dir() else "does not exist"
        raise LipSyncError(f"the arousal model file {path}{named} {problem}")
    try:
        stamp = path.stat().st_mtime_ns
    except OSError:
        stamp = -1   # unreadable: reading it says why
    return copy.deepcopy(_read_model(path, stamp))


@lru_cache(maxsize=4)
def _read_model(path: Path, stamp: int) -> dict:
    """:func:`load_model`'s reading and checking, for one version of a file."""
    doc = datafile.read_object(path)
    try:
        feats = doc["features"]
        for name, c in feats.items():
            if name not in FEATURES:
                raise LipSyncError(f"arousal model {path}: unknown feature {name!r} "
                                   f"(known: {', '.join(FEATURES)})")
            for k in ("center", "scale", "weight"):
                float(c[k])
            if float(c["scale"]) <= 0:
                raise LipSyncError(f"arousal model {path}: features.{name}.scale must be positive")
        float(doc["bias"])
    except (KeyError, TypeError, ValueError) as exc:
        raise LipSyncError(f"arousal model {path}: malformed ({exc!r}); it needs bias and "
                           "features.<name>.{center, scale, weight}") from None
    return doc


def frames(audio: Audio, tracks: prosody.Tracks | None = None, speech_db: float = 35.0) -> Frames:
    """Pitch, intensity and spectral centroid every 10 ms."""
    tracks = tracks if tracks is not None else prosody.analyse(audio, step=STEP)
    n = len(tracks.times)
    samples = audio.samples   # an array, or a long WAV file read a stretch at a time
    win = int(round(0.025 * audio.rate))
    cen = np.full(n, np.nan)
    if len(samples) >= win and n:
        starts = np.clip((tracks.times * audio.rate).astype(int) - win // 2, 0, len(samples) - win)
        fq = np.fft.rfftfreq(win, 1.0 / audio.rate)
        band = (fq >= 50) & (fq <= 5000)
        hann = np.hanning(win)
        for a in range(0, n, 4096):  # in blocks: long recordings stay small in memory
            st = starts[a:a + 4096]
            x = np.asarray(samples[int(st[0]):int(st[-1]) + win], dtype=np.float64)
            seg = x[(st - st[0])[:, None] + np.arange(win)] * hann
            p = (np.abs(np.fft.rfft(seg, axis=1)) ** 2)[:, band]
            tot = p.sum(axis=1)
            ok = tot > 0
            c = np.full(len(p), np.nan)
            c[ok] = np.log2((p[ok] * fq[band]).sum(axis=1) / tot[ok] / 1000.0)
            cen[a:a + 4096] = c
    inten = np.asarray(tracks.intensity, dtype=float)
    speech = inten > (inten.max() - speech_db) if n else np.zeros(0, bool)
    with np.errstate(divide="ignore", invalid="ignore"):
        st = 12.0 * np.log2(tracks.pitch / 100.0)
    return Frames(tracks.times, st, inten, cen, speech & np.isfinite(cen))


def features(fr: Frames, lo: int = 0, hi: int | None = None) -> dict[str, float]:
    """The features over frames ``lo:hi`` (default: all)."""
    sl = slice(lo, len(fr.times) if hi is None else hi)
    sp = fr.speech[sl]
    out = {k: float("nan") for k in FEATURES}
    if sp.sum() < 3:
        return out
    pitch = fr.pitch_st[sl]
    voiced = sp & np.isfinite(pitch)
    if voiced.sum() >= 3:
        out["pitch"] = float(np.median(pitch[voiced]))
    out["voiced"] = float(voiced.sum() / sp.sum())
    out["centroid"] = float(np.median(fr.centroid[sl][sp]))
    pair = sp[1:] & sp[:-1]
    if pair.sum() >= 2:
        out["dynamics"] = float(np.mean(np.abs(np.diff(fr.intensity[sl]))[pair]))
    return out


def score(feats: dict[str, float], model: dict, fallback: dict[str, float] | None = None) -> float:
    """The model on one feature set: tanh(bias + sum weight * (x - center) / scale).

    A feature that is missing (NaN) takes ``fallback``'s value, else its centre."""
    z = float(model["bias"])
    for name, c in model["features"].items():
        v = feats.get(name, float("nan"))
        if v is None or not np.isfinite(v):
            v = (fallback or {}).get(name, float("nan"))
        if v is None or not np.isfinite(v):
            v = c["center"]
        z += float(c["weight"]) * (float(v) - float(c["center"])) / float(c["scale"])
    return float(np.tanh(z))


def speaking_rate(phones, duration: float) -> float:
    """Phonemes per second of speech (silences and pauses left out)."""
    spoken = [p for p in phones if p.phone not in ("SIL", "SP", "sil", "sp", "")]
    total = sum(p.end - p.start for p in spoken)
    return len(spoken) / total if total > 0 else float("nan")


def estimate(audio: Audio, tracks: prosody.Tracks | None = None, alignment=None,
             model: dict | None = None, window: float | None = None, hop: float | None = None,
             smooth: float | None = None, measured: Frames | None = None) -> Estimate:
    """The clip's arousal and its track.  ``tracks``: prosody already measured
    (10 ms step); ``alignment``: adds the speaking rate; ``measured``: the
    :func:`frames` of this audio and tracks, already computed."""
    model = model or load_model()
    tr = model.get("track", {})
    window = float(window if window is not None else tr.get("window", 1.5))
    hop = float(hop if hop is not None else tr.get("hop", 0.1))
    smooth = float(smooth if smooth is not None else tr.get("smooth", 0.3))
    fr = measured if measured is not None else frames(audio, tracks, float(model.get("speech_db", 35.0)))
    feats = features(fr)
    if alignment is not None and getattr(alignment, "phones", None):
        feats["rate"] = speaking_rate(alignment.phones, alignment.duration)
    heard = any(np.isfinite(feats[k]) for k in ("pitch", "centroid", "dynamics", "voiced"))
    value = score(feats, model) if heard else 0.0   # nothing to judge: neutral
    if len(fr.times) == 0 or not heard:
        return Estimate(value, feats)
    centres = np.arange(0.0, audio.duration + hop / 2, hop)
    raw = _window_scores(fr, centres, window, model, feats)
    ok = np.isfinite(raw)
    raw = np.interp(centres, centres[ok], raw[ok]) if ok.any() else np.full(len(centres), value)
    if smooth > 0:
        raw = smoothing.gaussian(raw, smooth / hop)
    return Estimate(value, feats, centres, np.clip(raw, -1.0, 1.0))


def _window_scores(fr: Frames, centres: np.ndarray, window: float, model: dict, clip: dict) -> np.ndarray:
    """The model on the features of a ``window``-second window around each
    centre (all windows at once; NaN where a window holds under 3 speech
    frames).  A feature a window lacks takes the clip's value."""
    import warnings

    n, h = len(fr.times), max(1, int(round(window / 2 / STEP)))
    idx = np.clip(np.searchsorted(fr.times, centres), 0, n - 1)
    sp = fr.speech
    voiced = sp & np.isfinite(fr.pitch_st)
    pair = np.zeros(n, bool)
    pair[:-1] = sp[1:] & sp[:-1]
    d_int = np.zeros(n)
    d_int[:-1] = np.abs(np.diff(fr.intensity))

    def rows(x, fill):
        padded = np.concatenate([np.full(h, fill, dtype=x.dtype), x, np.full(h, fill, dtype=x.dtype)])
        return np.lib.stride_tricks.sliding_window_view(padded, 2 * h + 1)[idx]

    def count(mask):
        c = np.concatenate([[0], np.cumsum(mask)])
        lo, hi = np.clip(idx - h, 0, n), np.clip(idx + h + 1, 0, n)
        return c[hi] - c[lo]

    n_sp, n_v, n_pair = count(sp), count(voiced), count(pair)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)   # all-NaN windows: handled below
        f = {"pitch": np.nanmedian(rows(np.where(voiced, fr.pitch_st, np.nan), np.nan), axis=1),
             "centroid": np.nanmedian(rows(np.where(sp, fr.centroid, np.nan), np.nan), axis=1),
             "voiced": n_v / np.maximum(n_sp, 1),
             "dynamics": np.where(n_pair >= 2, count(np.where(pair, d_int, 0.0)) / np.maximum(n_pair, 1), np.nan)}
    f["pitch"][n_v < 3] = np.nan
    z = np.full(len(centres), float(model["bias"]))
    for name, c in model["features"].items():
        x = f.get(name, np.full(len(centres), np.nan)).astype(float)
        fallback = clip.get(name, float("nan"))
        x = np.where(np.isfinite(x), x, fallback if fallback is not None and np.isfinite(fallback) else c["center"])
        z += float(c["weight"]) * (x - float(c["center"])) / float(c["scale"])
    out = np.tanh(z)
    out[n_sp < 3] = np.nan
    return out


def estimate_file(path: str | os.PathLike, model: dict | None = None) -> Estimate:
    from . import audio as audio_mod

    snd = audio_mod.load(path)
    if snd.duration < 0.1:
        raise LipSyncError(f"audio file {os.fspath(path)} is too short to judge ({snd.duration:.3f} s)")
    est = estimate(snd, model=model)
    if not np.isfinite(est.features["centroid"]):
        raise LipSyncError(f"audio file {os.fspath(path)} holds no speech to judge (silence)")
    return est


# ---------------------------------------------------------------------------
# Fitting (used by bench/arousal.py and by studios refitting on their own clips)

def fit(rows: list[dict[str, float]], labels, names=("pitch", "centroid", "dynamics", "voiced"),
        ridge: float = 3.0) -> dict:
    """Ridge regression of atanh(label) on the standardised features ->
    a model dict (the shape of ``data/arousal.json``)."""
    X = np.array([[r[n] for n in names] for r in rows], dtype=float)
    y = np.arctanh(np.clip(np.asarray(labels, dtype=float), -0.95, 0.95))
    center = np.nanmean(X, axis=0)
    X = np.where(np.isfinite(X), X, center)
    scale = X.std(axis=0)
    scale[scale <= 0] = 1.0
    Z = (X - center) / scale
    A = np.c_[np.ones(len(Z)), Z]
    reg = ridge * np.eye(A.shape[1])
    reg[0, 0] = 0.0
    w = np.linalg.solve(A.T @ A + reg, A.T @ y)
    return {"bias": float(w[0]),
            "features": {n: {"center": float(center[k]), "scale": float(scale[k]), "weight": float(w[k + 1])}
                         for k, n in enumerate(names)}}


def range_factor(values, amount: float, model: dict | None = None) -> np.ndarray:
    """What a preset with ``weights.follow_voice`` = ``amount`` multiplies the
    viseme weight ranges by at arousal ``values``: 1 + amount * r * arousal,
    with r the model file's ``follow_voice_range`` (0.35: x1.35 at full
    arousal and amount 1, x0.65 at the calmest).  Amount 0 gives exactly 1."""
    r = float((model or load_model()).get("follow_voice_range", 0.35))
    return 1.0 + float(amount) * r * np.clip(np.asarray(values, dtype=float), -1.0, 1.0)
