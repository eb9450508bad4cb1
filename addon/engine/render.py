"""From an aligned line to viseme curves, under one preset or several.

This is the animation step of the method, after alignment and the voice
measurements: each phoneme's viseme weight from its pitch and intensity
(equations 1-2, :func:`phoneme_weights`), then coarticulation (the rule
model or Cohen-Massaro dominance), smoothing, rest in the pauses and the
lips closed on /p b m/ (:func:`curves`).  :func:`render` does it for a whole
line whose emotion may change inside it (inline tags, timeline markers),
mixing the curves of the presets involved as :mod:`.emotion_track` says,
and with them the expression of each preset on the whole face
(:mod:`.expression`).

The pipeline, the emotion track and the learner all render through here.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import arousal as arousal_mod
from . import coarticulation, expression, pauses, prosody, visemes, weights
from .alignment import Alignment
from .coarticulation import check_model
from .emotion_track import Change, mix
from .errors import LipSyncError
from .framerate import frame_times
from .language import phone_class
from .presets import Preset, viseme_set_for
from .settings import LineSettings


def phone_ranges(phones: list[str], vset: visemes.VisemeSet, preset: Preset) -> np.ndarray:
    """(W_min, W_p, W_max) of each phoneme's (first) viseme, scaled by the preset."""
    scale = preset.weights.range_scale
    out = np.zeros((len(phones), 3))
    for k, p in enumerate(phones):
        vs = vset.of(p)
        base = vset.ranges[vset.index(vs[0])] if vs else np.zeros(3)
        out[k] = np.clip(base * np.asarray(scale[phone_class(p)]), 0.0, 1.0)
    return out


def phoneme_weights(alignment: Alignment, pitch: np.ndarray, intensity: np.ndarray, stats: prosody.ClipStats,
                    vset: visemes.VisemeSet, preset: Preset, arousal: np.ndarray | None = None) -> np.ndarray:
    """Equations 1-2: each phoneme's viseme weight from its pitch and intensity.
    ``arousal`` (per phoneme, -1 to 1) widens or narrows the ranges by the
    preset's ``weights.follow_voice``."""
    phones = [p.phone for p in alignment.phones]
    ranges = phone_ranges(phones, vset, preset)
    amount = preset.weights.follow_voice
    if arousal is not None and amount > 0 and len(phones):
        ranges = np.clip(ranges * arousal_mod.range_factor(arousal, amount)[:, None], 0.0, 1.0)
    return weights.phoneme_weights(phones, pitch, intensity, stats, ranges, preset.weights.other_source)


def rest_target(vset: visemes.VisemeSet, preset: Preset) -> tuple[int | None, float]:
    """The viseme silence shows and its weight (None, 0: silence is the basis)."""
    rest = vset.rest
    if not rest:
        return None, 0.0
    i = vset.index(rest)
    return i, float(vset.ranges[i][1] * preset.weights.range_scale["silence"][1])


def curves(alignment: Alignment, pitch: np.ndarray, intensity: np.ndarray, stats: prosody.ClipStats,
           vset: visemes.VisemeSet, preset: Preset, model: str, fps: float, arousal: np.ndarray | None = None
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One preset's (weight per phoneme, frame times, viseme curves (frames, visemes))."""
    check_model(model)
    w = phoneme_weights(alignment, pitch, intensity, stats, vset, preset, arousal)
    times = frame_times(alignment.duration, fps)
    spans = [(p.phone, p.start, p.end) for p in alignment.phones]
    split = preset.rules.diphthong_split
    n_v = len(vset.visemes)
    if model == "rules":
        de = preset.rules.deletion
        kept, kw = coarticulation.delete_short(spans, w, de.phones, de.threshold)
        events = coarticulation.build_events(kept, kw, vset, split)
        out = coarticulation.rules(events, times, n_v, preset)
    else:
        events = coarticulation.build_events(spans, w, vset, split)
        rest_i, rest_w = rest_target(vset, preset)
        out = coarticulation.dominance(events, times, n_v, preset, alignment.duration, rest_i, rest_w)
    out = coarticulation.smooth(out, fps, preset.smoothing)
    out = pauses.force_rest(out, times, [(p.start, p.end) for p in alignment.phones], alignment.duration)
    out = coarticulation.enforce_closures(out, times, events, preset.closure_strength)
    out = np.clip(out * preset.gain, 0.0, 1.0)
    return w, times, out


@dataclass
class Rendered:
    """A rendered line: per phoneme its pitch (Hz, NaN where unvoiced),
    intensity (dB) and viseme weight; the frame times and the viseme curves
    (frames, visemes) in [0, 1]; the clip's voice statistics; and the
    expression, one curve per FACS action unit (none under neutral)."""

    pitch: np.ndarray
    intensity: np.ndarray
    weights: np.ndarray
    times: np.ndarray
    curves: np.ndarray
    stats: prosody.ClipStats
    expression: dict[str, np.ndarray] = field(default_factory=dict)


def render(al: Alignment, tracks: prosody.Tracks, settings: LineSettings, changes: list[Change] = (), *,
           estimate: arousal_mod.Estimate | None = None) -> Rendered:
    """The line's curves, with the emotion starting as ``settings.emotion``
    and following ``changes`` (see :func:`.emotion_track.mix`, over
    ``settings.emotion_fade``); with no change, exactly that preset's own.
    ``estimate`` is the voice's arousal, followed by presets whose
    ``weights.follow_voice`` is above 0.  Every preset of the line must
    agree on the viseme set (``settings.viseme_set``, the one the user
    asked for)."""
    base, vset, viseme_set = settings.emotion, settings.visemes, settings.viseme_set
    model, fps, fade = settings.coarticulation, settings.fps, settings.emotion_fade
    starting = [c for c in changes if c.time <= 0]
    if starting:
        base = starting[-1].preset
    later = sorted((c for c in changes if c.time > 0), key=lambda c: c.time)
    plist, keys = [base], [base.key()]
    index = []
    for c in later:
        key = c.preset.key()
        if key not in keys:
            plist.append(c.preset)
            keys.append(key)
        index.append(keys.index(key))
    centres = np.array([(p.start + p.end) / 2 for p in al.phones])
    spans = [(p.start, p.end) for p in al.phones]
    phones = [(p.phone, p.start, p.end) for p in al.phones]
    results, faces = [], []
    voice = None
    for p in plist:
        if changes and viseme_set_for(p, viseme_set).name != vset.name:
            raise LipSyncError(f"preset {p.name!r} uses the {viseme_set_for(p, viseme_set).name!r} "
                               f"viseme set, the line's others {vset.name!r}: they cannot be mixed in one line")
        stats, pitch, inten = prosody.for_preset(tracks, spans, p.weights)
        follow = estimate.at(centres) if estimate is not None and p.weights.follow_voice > 0 else None
        w, times, out = curves(al, pitch, inten, stats, vset, p, model, fps, arousal=follow)
        if p.expression and voice is None and estimate is not None:
            voice = estimate.at(times)
        faces.append(expression.unit_curves(p.expression, times, phones, pitch, fps, voice)
                     if p.expression else {})
        results.append(Rendered(pitch, inten, w, times, out, stats, faces[-1]))
    first = results[0]
    if len(plist) == 1:
        return first
    m = mix(first.times, [c.time for c in later], len(plist), index, fade)
    out = np.clip(sum(m[:, k, None] * r.curves for k, r in enumerate(results)), 0.0, 1.0)
    mp = mix(centres, [c.time for c in later], len(plist), index, fade)
    w = sum(mp[:, k] * r.weights for k, r in enumerate(results)) if len(centres) else first.weights
    return Rendered(first.pitch, first.intensity, w, first.times, out, first.stats, expression.mix(faces, m))
