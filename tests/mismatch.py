"""Synthetic captures from a generator that is NOT the engine's dominance
model: for learning tests and the model-mismatch benchmark.

Each phoneme has a hand-made articulatory target (jaw opening, lip
aperture, lip rounding, 0-1; a diphthong moves from one target to another
over its span).  The articulators track the target sequence as a
critically damped second-order system whose stiffness depends on the
phoneme's class (lips close fast on /p b m/, the jaw drifts through
alveolars), run forward and backward in time and averaged, so they
anticipate a gesture as much as they carry it over.  The "capture" then
lags the sound by a delay, scales and offsets each track as a sensor's
units would, and adds noise.
"""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
FIXTURES = ROOT / "tests" / "fixtures"
SAMPLE = ROOT / "sample_rigs" / "speech"
TRACKS = ("jaw", "lip_aperture", "rounding")

#: Phoneme -> (jaw, lip aperture, rounding); a diphthong: (start, end).
_V = {"AA": (0.9, 0.85, 0.05), "AE": (0.75, 0.7, 0.0), "AH": (0.55, 0.5, 0.1), "AO": (0.75, 0.6, 0.6),
      "EH": (0.6, 0.55, 0.0), "ER": (0.3, 0.3, 0.5), "IH": (0.3, 0.35, 0.0), "IY": (0.2, 0.3, 0.0),
      "UH": (0.35, 0.3, 0.65), "UW": (0.2, 0.15, 1.0)}
_DIPHTHONGS = {"AW": ("AA", "UH"), "AY": ("AA", "IH"), "EY": ("EH", "IY"), "OW": ("AO", "UW"), "OY": ("AO", "IY")}
_C = {"P": (0.1, 0.0, 0.15), "B": (0.1, 0.0, 0.15), "M": (0.1, 0.0, 0.15), "F": (0.12, 0.08, 0.0),
      "V": (0.12, 0.08, 0.0), "TH": (0.2, 0.3, 0.0), "DH": (0.2, 0.3, 0.0), "T": (0.15, 0.25, 0.0),
      "D": (0.15, 0.25, 0.0), "N": (0.15, 0.25, 0.0), "S": (0.1, 0.2, 0.0), "Z": (0.1, 0.2, 0.0),
      "L": (0.3, 0.35, 0.0), "SH": (0.15, 0.3, 0.7), "ZH": (0.15, 0.3, 0.7), "CH": (0.15, 0.3, 0.7),
      "JH": (0.15, 0.3, 0.7), "K": (0.3, 0.35, 0.1), "G": (0.3, 0.35, 0.1), "NG": (0.3, 0.35, 0.1),
      "HH": (0.45, 0.45, 0.0), "R": (0.3, 0.3, 0.55), "W": (0.15, 0.1, 0.95), "Y": (0.2, 0.3, 0.0),
      "SIL": (0.05, 0.02, 0.1)}
#: Stiffness (rad/s) of the tracking while a phoneme of each kind sounds.
_STIFF = {"bilabial": 120.0, "labiodental": 90.0, "vowel": 45.0, "alveolar": 30.0, "velar": 30.0,
          "postalveolar": 55.0, "dental": 50.0, "liquid": 40.0, "glide": 50.0, "silence": 20.0}


def _targets(phone: str, frac: float):
    if phone in _DIPHTHONGS:
        a, b = _DIPHTHONGS[phone]
        return _V[a] if frac < 0.5 else _V[b]
    return _V.get(phone) or _C.get(phone) or _C["SIL"]


def articulate(alignment, duration: float, rate: float = 1000.0):
    """(times, (samples, 3) jaw / lip aperture / rounding) on a ``rate`` Hz grid."""
    from addon.engine.language.phonemes import phone_class

    t = np.arange(int(duration * rate) + 1) / rate
    goal = np.tile(np.array(_C["SIL"]), (len(t), 1))
    stiff = np.full(len(t), _STIFF["silence"])
    for p in alignment.phones:
        m = (t >= p.start) & (t < p.end)
        if not m.any():
            continue
        frac = (t[m] - p.start) / max(p.end - p.start, 1e-9)
        goal[m] = [_targets(p.phone, f) for f in frac]
        stiff[m] = _STIFF[phone_class(p.phone)] if p.phone != "SIL" else _STIFF["silence"]

    def track(g, w):
        x, v = g[0].copy(), np.zeros(3)
        out = np.empty_like(g)
        dt = 1.0 / rate
        for i in range(len(g)):
            v += dt * (w[i] ** 2 * (g[i] - x) - 2 * w[i] * v)
            x = x + dt * v
            out[i] = x
        return out

    x = 0.5 * (track(goal, stiff) + track(goal[::-1], stiff[::-1])[::-1])
    return t, x


def capture(alignment, duration: float, *, delay: float = 0.045, gain=(1.4, 0.7, 1.2), offset=(0.1, 0.05, -0.05),
            noise: float = 0.02, rate: float = 100.0, rng=None):
    """(times from 0, (frames, 3) tracks): the articulation as a sensor
    records it, ``delay`` s late, in its own units, with noise."""
    rng = rng or np.random.default_rng(0)
    t_art, x = articulate(alignment, duration)
    times = np.arange(int(duration * rate) + 1) / rate
    y = np.stack([np.interp(times - delay, t_art, x[:, j]) for j in range(3)], axis=1)
    return times, y * np.asarray(gain) + np.asarray(offset) + rng.normal(0.0, noise, y.shape) * np.asarray(gain)


def stretch(snd, al, f):
    """The clip and its alignment played ``f`` times as long."""
    from addon.engine import audio as audio_mod

    n = int(len(snd.samples) * f)
    x = np.linspace(0, len(snd.samples) - 1, n)
    s2 = audio_mod.Audio(np.interp(x, np.arange(len(snd.samples)), snd.samples).astype(np.float32), snd.rate)
    a2 = copy.deepcopy(al)
    for item in list(a2.words) + list(a2.phones):
        item.start *= f
        item.end *= f
    a2.duration = al.duration * f
    return s2, a2


def sources():
    """(name, audio path, transcript) of the project's own speech."""
    return [("bob_map", FIXTURES / "bob_map.wav", (FIXTURES / "bob_map.txt").read_text()),
            ("fast_bilabials", FIXTURES / "fast_bilabials.wav", (FIXTURES / "fast_bilabials.txt").read_text()),
            ("hello", SAMPLE / "hello.wav", (SAMPLE / "hello.txt").read_text()),
            ("pause", FIXTURES / "pause.wav", "First part of the line. And the second part after a long pause.")]


def clips(rates=(0.9, 1.15), delay: float = 0.045, seed: int = 3, names=None, **kw):
    """Training clips with synthetic captures of the three proxy tracks
    (``names``: of these sources only)."""
    from addon.engine import audio as audio_mod
    from addon.engine.alignment import align_audio
    from addon.engine.learning import TrainingClip

    rng = np.random.default_rng(seed)
    out = []
    for name, path, text in sources():
        if names is not None and name not in names:
            continue
        snd = audio_mod.load(path)
        al = align_audio(snd, text)
        for f in rates:
            s2, a2 = (snd, al) if f == 1.0 else stretch(snd, al, f)
            times, y = capture(a2, s2.duration, delay=delay, rng=rng, **kw)
            out.append(TrainingClip(f"{name}@{f}", s2, a2, times, y, list(TRACKS)))
    return out
