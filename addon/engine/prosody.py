"""Pitch and intensity of the speech (Praat, through parselmouth), summarised
per phoneme and per clip for equations 1 and 2 of the first paper."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .audio import Audio
from .presets import Weights

#: Pitch ranges cited by the paper (Baken & Orlikoff), Hz.
PITCH_RANGES = {"male": (85.0, 180.0), "female": (165.0, 255.0)}


@dataclass
class Tracks:
    times: np.ndarray       # s, frame centres
    pitch: np.ndarray       # Hz, NaN where unvoiced
    intensity: np.ndarray   # dB


@dataclass
class ClipStats:
    f_min: float
    f_mean: float
    f_max: float
    i_min: float
    i_mean: float
    i_max: float
    voiced: bool            # any voiced frame at all


#: Long clips are analysed in pieces of this many seconds (with margins on
#: both sides, dropped), so Praat never holds a copy of a whole recording.
PIECE = 60.0
_PIECE_MARGIN = 1.0


def analyse(audio: Audio, pitch_floor: float = 75.0, pitch_ceiling: float = 600.0,
            step: float = 0.01) -> Tracks:
    """Pitch (autocorrelation) and intensity tracks every ``step`` seconds."""
    if audio.duration < 0.1:
        t = np.arange(0, audio.duration, step) + step / 2
        return Tracks(t, np.full(len(t), np.nan), np.full(len(t), -300.0))
    times = np.arange(len(audio.samples) // int(audio.rate * step)) * step + step / 2
    if audio.duration <= PIECE + 2 * _PIECE_MARGIN:
        p, i = _piece(audio.samples, audio.rate, 0.0, times, pitch_floor, pitch_ceiling, step)
        return Tracks(times, p, i)
    p, i = np.empty(len(times)), np.empty(len(times))
    for t0 in np.arange(0.0, audio.duration, PIECE):
        sel = (times >= t0) & (times < t0 + PIECE)
        a = int(max(0.0, t0 - _PIECE_MARGIN) * audio.rate)
        b = int(min(audio.duration, t0 + PIECE + _PIECE_MARGIN) * audio.rate)
        p[sel], i[sel] = _piece(audio.samples[a:b], audio.rate, a / audio.rate, times[sel],
                                pitch_floor, pitch_ceiling, step)
    return Tracks(times, p, i)


def _piece(samples: np.ndarray, rate: float, start: float, times: np.ndarray, pitch_floor: float,
           pitch_ceiling: float, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Pitch and intensity at ``times`` from the samples beginning at ``start`` s."""
    import parselmouth

    snd = parselmouth.Sound(samples.astype(np.float64), sampling_frequency=rate, start_time=start)
    pitch = snd.to_pitch(time_step=step, pitch_floor=pitch_floor, pitch_ceiling=pitch_ceiling)
    f0 = pitch.selected_array["frequency"].astype(float)
    f0[f0 <= 0] = np.nan
    inten = snd.to_intensity(minimum_pitch=100.0, time_step=step, subtract_mean=False)
    p = np.interp(times, pitch.xs(), f0, left=np.nan, right=np.nan)
    # Linear interpolation of f0 turns a frame next to an unvoiced one into a
    # mean with NaN: keep the nearest frame's voicing instead.
    nearest = np.clip(np.searchsorted(pitch.xs(), times), 0, len(f0) - 1) if len(f0) else None
    if nearest is not None:
        p[np.isnan(f0[nearest])] = np.nan
    i = np.interp(times, inten.xs(), inten.values[0]) if inten.values.size else np.full(len(times), -300.0)
    return p, i


def clip_stats(tracks: Tracks, intensity_floor_db: float = 50.0,
               pitch_range: str | tuple[float, float] = "auto") -> ClipStats:
    """Extremes and means over the clip.

    Pitch extremes are the 5th and 95th percentiles of voiced frames, not the
    raw extremes, so one octave error does not squash every other phoneme's
    weight.  ``pitch_range`` "male"/"female"/(lo, hi) overrides them.
    Intensity counts frames within ``intensity_floor_db`` of the loudest
    frame; quieter ones are silence (digital silence reads -300 dB).
    """
    voiced = tracks.pitch[np.isfinite(tracks.pitch)]
    if len(voiced) >= 3:
        f_min, f_max = np.percentile(voiced, [5, 95])
        f_mean = float(np.mean(np.clip(voiced, f_min, f_max)))
        has_voice = True
    else:
        f_min, f_mean, f_max = 100.0, 150.0, 200.0
        has_voice = False
    if pitch_range != "auto":
        lo, hi = PITCH_RANGES[pitch_range] if isinstance(pitch_range, str) else pitch_range
        f_min, f_max = float(lo), float(hi)
        f_mean = float(np.clip(f_mean, f_min, f_max)) if has_voice else (f_min + f_max) / 2
    loud = tracks.intensity.max() if len(tracks.intensity) else 0.0
    floor = loud - intensity_floor_db
    speech = tracks.intensity[tracks.intensity > floor]
    if len(speech) >= 1:
        i_min, i_mean, i_max = floor, float(speech.mean()), float(loud)
    else:
        i_min, i_mean, i_max = floor, floor, float(loud)
    return ClipStats(float(f_min), float(f_mean), float(f_max), float(i_min), i_mean, i_max, has_voice)


def for_preset(tracks: Tracks, spans: list[tuple[float, float]], weights: Weights
               ) -> tuple[ClipStats, np.ndarray, np.ndarray]:
    """The clip's extremes (:func:`clip_stats`) as a preset's ``weights``
    section reads them (its ``intensity_floor_db`` and ``pitch_range``), and
    each span's mean pitch and intensity (:func:`phoneme_means`)."""
    stats = clip_stats(tracks, weights.intensity_floor_db, weights.pitch_range)
    pitch, inten = phoneme_means(tracks, spans, stats)
    return stats, pitch, inten


def phoneme_means(tracks: Tracks, spans: list[tuple[float, float]], stats: ClipStats
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Mean pitch and intensity over each (start, end) span.

    Unvoiced phonemes (no voiced frame in their span) take the pitch of the
    voiced frames around them, interpolated; in a clip with no voice at all
    (whisper) pitch stays NaN and the weight equations fall back to the
    neutral weight.  Intensity is clamped at the clip's silence floor.
    """
    t = tracks.times
    f = tracks.pitch
    ok = np.isfinite(f)
    filled = np.interp(t, t[ok], f[ok]) if ok.sum() >= 1 else np.full(len(t), np.nan)
    inten = np.maximum(tracks.intensity, stats.i_min)
    pitch_out = np.full(len(spans), np.nan)
    int_out = np.full(len(spans), stats.i_min)
    for k, (a, b) in enumerate(spans):
        lo, hi = np.searchsorted(t, a), np.searchsorted(t, b)
        if hi <= lo:  # shorter than a frame: nearest frame
            lo = min(max(0, np.searchsorted(t, (a + b) / 2) - 1), max(0, len(t) - 1))
            hi = lo + 1
        seg = f[lo:hi]
        voiced = seg[np.isfinite(seg)]
        pitch_out[k] = voiced.mean() if len(voiced) else (filled[lo:hi].mean() if len(filled) else np.nan)
        if len(inten[lo:hi]):
            int_out[k] = inten[lo:hi].mean()
    return pitch_out, int_out
