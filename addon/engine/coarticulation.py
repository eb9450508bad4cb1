"""Coarticulation: from weighted visemes with times to smooth curves.

Two models, chosen per run:

``rules``  (Charalambous et al., section 2.1)  Each viseme rises from zero
    before its phoneme starts, peaks at the phoneme's apex and falls back to
    zero after it ends.  The onset and offset windows are ``t_onset`` and
    ``t_offset`` times an influence factor ``c`` chosen by context
    (vowel/consonant before -> this), and never longer than the neighbouring
    phoneme, so fast speech does not pile visemes up.  Short /h/ and /t/
    (the preset's deletion list) are dropped from the visual stream; a
    diphthong's span is split between its two visemes.  Where one viseme's
    events overlap, the higher one wins (max), so repeated visemes do not add
    up past their weight.

``dominance``  (Cohen & Massaro 1993, as used by Beskow & Nordenberg)  Every
    segment i, silences included, has a target vector T_i (its viseme times
    its weight; silence aims at the rest pose) and a dominance function
    ``alpha * exp(-theta * d**c)`` before its centre and
    ``alpha * exp(-phi * d**c)`` after it; the curve is
    ``sum_i T_i D_i(t) / sum_i D_i(t)``.  ``d`` is the distance from the
    centre less a plateau (``dominance.plateau`` times half the segment), so a
    long vowel or pause holds its target; plateau 0 is the classic model.

Both models then go through :func:`enforce_closures`: lips close on every
/p b m/ and the lower lip meets the teeth on every /f v/, whatever the speech
rate and frame rate.  During such a phoneme its viseme reaches its target
and the other visemes are suppressed by ``closure.strength``; a closure
shorter than a frame still gets the nearest frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import smoothing
from .errors import LipSyncError
from .pauses import settings as timing_settings
from .language.phonemes import SILENCE, phone_class
from .presets import Preset

#: The coarticulation models.
MODELS = ("dominance", "rules")
CLOSURE_CLASSES = ("bilabial", "labiodental")


def check_model(model: str) -> str:
    """``model`` if it names a coarticulation model, else a clear error."""
    if model not in MODELS:
        raise LipSyncError(f"unknown coarticulation model {model!r}: use {' or '.join(MODELS)}")
    return model


@dataclass
class Event:
    """One viseme occurrence: a phoneme, or half of a diphthong."""

    viseme: int          # column in the viseme set
    start: float
    end: float
    weight: float
    phone: str
    cls: str             # articulation class of the phoneme

    @property
    def centre(self) -> float:
        return (self.start + self.end) / 2


def build_events(phones: list[tuple[str, float, float]], weights: np.ndarray, vset,
                 split: float = 0.5) -> list[Event]:
    """Viseme events of aligned phonemes (diphthongs split at ``split``)."""
    events: list[Event] = []
    for (p, a, b), w in zip(phones, weights):
        targets = vset.of(p)
        if not targets:
            continue
        if len(targets) == 1:
            cuts = [a, b]
        else:
            first = a + (b - a) * split
            rest = np.linspace(first, b, len(targets))
            cuts = [a] + list(rest)
        cls = phone_class(p)
        for v, s, e in zip(targets, cuts[:-1], cuts[1:]):
            events.append(Event(vset.index(v), s, e, float(w), p, cls))
    return events


def delete_short(phones: list[tuple[str, float, float]], weights: np.ndarray, drop: list[str],
                 threshold: float):
    """Drop the preset's deletable phonemes shorter than ``threshold`` s."""
    keep = [k for k, (p, a, b) in enumerate(phones) if not (p in drop and b - a < threshold)]
    return [phones[k] for k in keep], weights[keep]


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.minimum(np.maximum(x, 0.0), 1.0)   # np.clip, without its per-call overhead
    return x * x * (3 - 2 * x)


def rules(events: list[Event], times: np.ndarray, n_visemes: int, preset: Preset) -> np.ndarray:
    """The rule-based model (see module docstring)."""
    r = preset.rules
    out = np.zeros((len(times), n_visemes))
    inf = r.influence
    for k, ev in enumerate(events):
        prev = events[k - 1] if k > 0 and events[k - 1].end >= ev.start - 0.03 else None
        nxt = events[k + 1] if k + 1 < len(events) and events[k + 1].start <= ev.end + 0.03 else None
        me = "V" if ev.cls == "vowel" else "C"
        if prev is not None:
            ctx = ("V" if prev.cls == "vowel" else "C") + me
            onset = inf[ctx] * min(r.t_onset, prev.end - prev.start)
        else:
            onset = r.t_onset   # from rest: the mouth has all the time it needs
        if nxt is not None:
            ctx = me + ("V" if nxt.cls == "vowel" else "C")
            offset = inf[ctx] * min(r.t_offset, nxt.end - nxt.start)
        else:
            offset = r.t_offset
        if ev.cls in CLOSURE_CLASSES:
            peak_a, peak_b = ev.start, ev.end        # hold the closure through the phoneme
        else:
            peak_a = peak_b = ev.start + r.apex * (ev.end - ev.start)
        lo = int(times.searchsorted(peak_a - onset - 1e-9))
        hi = int(times.searchsorted(peak_b + offset + 1e-9))
        if hi <= lo:
            continue
        t = times[lo:hi]
        rise = _smoothstep((t - (peak_a - onset)) / max(peak_a - (peak_a - onset), 1e-6)) if onset > 0 \
            else (t >= peak_a).astype(float)
        fall = _smoothstep(((peak_b + offset) - t) / max(offset, 1e-6)) if offset > 0 \
            else (t <= peak_b).astype(float)
        curve = ev.weight * np.where(t < peak_a, rise, np.where(t > peak_b, fall, 1.0))
        col = out[lo:hi, ev.viseme]
        np.maximum(col, curve, out=col)
    return out


def segments_with_silence(events: list[Event], duration: float, rest: int | None,
                          rest_weight: float) -> list[Event]:
    """Events plus silence segments in the gaps (and before/after speech)."""
    segs: list[Event] = []
    t = 0.0
    for ev in events:
        if ev.start - t > 1e-3:
            segs.append(Event(-1 if rest is None else rest, t, ev.start, rest_weight, SILENCE, "silence"))
        segs.append(ev)
        t = max(t, ev.end)
    if duration - t > 1e-3:
        segs.append(Event(-1 if rest is None else rest, t, duration, rest_weight, SILENCE, "silence"))
    return segs


def dominance_params(segs: list[Event], preset: Preset) -> np.ndarray:
    """(n, 4) array of alpha, theta, phi, c per segment from its class."""
    cl = preset.dominance.classes
    return np.array([[cl[s.cls].alpha, cl[s.cls].theta, cl[s.cls].phi, cl[s.cls].c] for s in segs], float)


def dominance_matrix(times: np.ndarray, centres: np.ndarray, half: np.ndarray,
                     params: np.ndarray) -> np.ndarray:
    """D[i, t] for the given segments (dense)."""
    d = times[None, :] - centres[:, None]
    dist = np.maximum(np.abs(d) - half[:, None], 0.0)
    rate = np.where(d < 0, params[:, 1:2], params[:, 2:3])
    c = params[:, 3:4]
    if not np.all(c == 1.0):  # the built-in presets' exponent: x ** 1 is x, and costly
        dist = dist ** c
    return params[:, 0:1] * np.exp(-rate * dist)


def dominance(events: list[Event], times: np.ndarray, n_visemes: int, preset: Preset,
              duration: float, rest: int | None, rest_weight: float = 0.0,
              block: int = 512) -> np.ndarray:
    """The Cohen-Massaro model (see module docstring)."""
    segs = segments_with_silence(events, duration, rest, rest_weight)
    out = np.zeros((len(times), n_visemes))
    if not segs or len(times) == 0:
        return out
    params = dominance_params(segs, preset)
    centres = np.array([s.centre for s in segs])
    half = preset.dominance.plateau * np.array([(s.end - s.start) / 2 for s in segs])
    targets = np.zeros((len(segs), n_visemes))
    for k, s in enumerate(segs):
        if s.viseme >= 0:
            targets[k, s.viseme] = s.weight
    # A segment's influence is negligible (1e-6 of its peak) beyond its reach.
    reach = half + (np.log(params[:, 0] / 1e-6 + 1.0) / np.minimum(params[:, 1], params[:, 2])) ** (1 / params[:, 3])
    lo_t, hi_t = centres - reach, centres + reach
    for b0 in range(0, len(times), block):
        t = times[b0:b0 + block]
        sel = np.flatnonzero((lo_t <= t[-1]) & (hi_t >= t[0]))
        if len(sel) == 0:
            sel = np.array([int(np.argmin(np.abs(centres - t.mean())))])
        D = dominance_matrix(t, centres[sel], half[sel], params[sel])
        den = D.sum(axis=0)
        out[b0:b0 + block] = (D.T @ targets[sel]) / np.maximum(den, 1e-300)[:, None]
    return out


def smooth(curves: np.ndarray, fps: float, sigma_s: float) -> np.ndarray:
    """Gaussian smoothing along time (frames x columns), sigma in seconds;
    curves too short or a sigma under 0.3 frames are returned as they are."""
    sigma = sigma_s * fps
    if sigma < 0.3 or len(curves) < 3:
        return curves
    return smoothing.gaussian(curves, sigma)


def _envelope(times: np.ndarray, ev: Event, ramp: float, approach: float | None = None,
              margin: float | None = None) -> tuple[int, int, np.ndarray]:
    """Frames [lo, hi) around ``ev`` and how closed the lips are on each.

    The lips are fully closed (1) on the core of the phoneme: its span less
    ``closure.margin`` seconds at either end (``data/timing.json``; never
    shorter than ``closure.min_core``), so a boundary the aligner puts a frame
    too late or too early does not close the lips on the neighbouring vowel.
    Outside the core they are only approaching: from ``approach``
    (``closure.approach``, below one half) at the core's edge down to 0 over
    ``ramp`` seconds.  A core with no frame in it gets the frame nearest the
    phoneme's centre.  ``approach=1, margin=0``: the whole phoneme, ramping
    from 1 at its edges."""
    cfg = timing_settings()["closure"]
    if approach is None:
        approach = cfg["approach"]
    margin = cfg["margin"] if margin is None else margin
    # Scalars in plain Python: this runs once per closure, thousands of times a line.
    margin = min(max((ev.end - ev.start - cfg["min_core"]) / 2, 0.0), margin)
    a, b = ev.start + margin, ev.end - margin
    lo = int(times.searchsorted(a - ramp))
    hi = int(times.searchsorted(b + ramp))
    t = times[lo:hi]
    inside = (t >= a) & (t <= b)
    if not inside.any():
        k = min(max(int(times.searchsorted(ev.centre)), 0), len(times) - 1)
        if k > 0 and abs(times[k - 1] - ev.centre) < abs(times[k] - ev.centre):
            k -= 1
        return k, k + 1, np.ones(1)
    outside = np.abs(t - np.minimum(np.maximum(t, a), b))   # distance to [a, b]
    return lo, hi, np.where(inside, 1.0, approach * (1.0 - np.minimum(outside / ramp, 1.0)))


def enforce_closures(curves: np.ndarray, times: np.ndarray, events: list[Event],
                     strength: float, ramp: float = 0.03) -> np.ndarray:
    """Make every bilabial and labiodental closure visible (module docstring).

    The other visemes are suppressed over the whole phoneme; the closure
    viseme reaches its target on the phoneme's core (:func:`_envelope`).  A
    closure viseme (one only closures map to) is also kept below what its
    closures allow during vowels: the dominance blend's tail of a strong
    closure must not pull the lips shut inside an open vowel, so there the
    viseme is capped by the closures' approach envelopes, fading over
    ``closure.tail`` seconds (``data/timing.json``)."""
    if len(times) == 0:
        return curves
    out = curves
    for lo, hi, v, weight, suppress, raise_ in closure_steps(times, events, ramp):
        own = out[lo:hi, v].copy()
        out[lo:hi] *= (1.0 - strength * suppress)[:, None]
        out[lo:hi, v] = np.where(raise_ > 0, np.maximum(own, weight * raise_), own)
    for v, (frames, cap) in closure_caps(times, events).items():
        out[frames, v] = np.minimum(out[frames, v], cap)
    return out


def closure_steps(times: np.ndarray, events: list[Event], ramp: float = 0.03) -> list:
    """Per /p b m f v/ event, in order, what :func:`enforce_closures` does
    to the frames [lo, hi) around it: (lo, hi, viseme, weight, suppress,
    raise), where on each frame the other visemes are scaled by
    ``1 - strength * suppress`` and the viseme is raised to at least
    ``weight * raise``.  The learner applies the same steps to the
    derivatives of the curves."""
    out = []
    if len(times) == 0:
        return out
    for ev in events:
        if ev.cls not in CLOSURE_CLASSES:
            continue
        lo1, hi1, suppress = _envelope(times, ev, ramp, approach=1.0, margin=0.0)
        lo2, hi2, raise_ = _envelope(times, ev, ramp)
        lo, hi = min(lo1, lo2), max(hi1, hi2)
        s, r = np.zeros(hi - lo), np.zeros(hi - lo)
        s[lo1 - lo:hi1 - lo] = suppress
        r[lo2 - lo:hi2 - lo] = raise_
        out.append((int(lo), int(hi), ev.viseme, float(ev.weight), s, r))
    return out


def closure_caps(times: np.ndarray, events: list[Event]) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """For each closure viseme (one only closures map to): the vowel frames
    and the most that viseme may show on them (see :func:`enforce_closures`)."""
    tail = timing_settings()["closure"]["tail"]
    own_only = {ev.viseme for ev in events if ev.cls in CLOSURE_CLASSES} - \
        {ev.viseme for ev in events if ev.cls not in CLOSURE_CLASSES}
    if not own_only or len(times) == 0:
        return {}
    vowel = np.zeros(len(times), bool)
    for ev in events:
        if ev.cls == "vowel":
            lo, hi = np.searchsorted(times, [ev.start, ev.end])
            vowel[lo:hi] = True
    frames = np.flatnonzero(vowel)
    cap = {v: np.zeros(len(times)) for v in own_only}
    for ev in events:
        if ev.viseme in cap:
            lo, hi, env = _envelope(times, ev, tail)
            np.maximum(cap[ev.viseme][lo:hi], ev.weight * env, out=cap[ev.viseme][lo:hi])
    return {v: (frames, c[frames]) for v, c in cap.items()}


def closure_track(times: np.ndarray, phones: list[tuple[str, float, float]], ramp: float = 0.03) -> np.ndarray:
    """Per frame, how fully the lips must be closed: 1 during every /p b m/,
    approaching from below one half over ``ramp`` seconds either side (see
    :func:`_envelope`), 0 elsewhere.  A rig applies it the
    way its shape keys close the lips (:mod:`.conventions`)."""
    out = np.zeros(len(times))
    if len(times) == 0:
        return out
    for phone, start, end in phones:
        if phone_class(phone) != "bilabial":
            continue
        lo, hi, env = _envelope(times, Event(-1, start, end, 1.0, phone, "bilabial"), ramp)
        out[lo:hi] = np.maximum(out[lo:hi], env)
    return out
