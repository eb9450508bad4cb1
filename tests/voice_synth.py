"""A crude synthetic voice for tests: a glottal pulse train through vowel
formants, in syllables.  ``effort`` from 0 (soft, dark, steady) to 1 (loud,
bright, punctuated) moves what raised vocal effort moves: pitch, spectral
tilt, level and the contrast between syllables."""

from __future__ import annotations

import numpy as np

from addon.engine.alignment import AlignedPhone, AlignedWord, Alignment
from addon.engine.audio import Audio

RATE = 16000
FORMANTS = {"AA": (730, 1090, 2440), "IY": (270, 2290, 3010), "UW": (300, 870, 2240), "EH": (530, 1840, 2480)}


def _resonator(x, f, bw, rate=RATE):
    r = np.exp(-np.pi * bw / rate)
    a1, a2 = 2 * r * np.cos(2 * np.pi * f / rate), -r * r
    y = np.zeros_like(x)
    y1 = y2 = 0.0
    g = 1 - r
    for k in range(len(x)):
        y0 = g * x[k] + a1 * y1 + a2 * y2
        y[k] = y0
        y2, y1 = y1, y0
    return y


def voice(effort: float, syllables=("AA", "IY", "UW", "EH", "AA", "IY"), syl=0.22, gap=0.08,
          lead=0.3, seed=0) -> tuple[Audio, Alignment]:
    """Audio and its exact alignment: one word per syllable, each a vowel
    between two consonants (M ... S)."""
    rng = np.random.default_rng(seed)
    f0 = 110.0 * 2 ** (effort * 7 / 12)             # up to 7 semitones higher
    tilt = 0.97 - 0.6 * effort                        # one-pole low-pass: darker at low effort
    level = 0.03 + 0.3 * effort
    n = int(RATE * (lead * 2 + len(syllables) * (syl + gap)))
    out = np.zeros(n)
    phones, words = [], []
    t = lead
    for k, v in enumerate(syllables):
        a, b = int(t * RATE), int((t + syl) * RATE)
        m = b - a
        tt = np.arange(m) / RATE
        f = f0 * (1 + 0.08 * effort * np.sin(np.pi * tt / syl))
        phase = np.cumsum(f / RATE)
        pulses = np.diff(np.floor(phase), prepend=0.0)
        src = np.zeros(m)
        for j in range(1, m):
            src[j] = (1 - tilt) * pulses[j] + tilt * src[j - 1]
        sig = sum(_resonator(src, fr, 80 + 40 * i) * (0.5 ** i) for i, fr in enumerate(FORMANTS[v]))
        env = np.sin(np.pi * np.arange(m) / m) ** (0.5 + 2.5 * effort)   # sharper syllables with effort
        seg = sig * env
        out[a:b] += level * seg / (np.abs(seg).max() + 1e-9)
        s0, s1 = t, t + syl
        words.append(AlignedWord(f"w{k}", s0, s1, ["M", v, "S"]))
        phones += [AlignedPhone("M", s0, s0 + 0.05, k), AlignedPhone(v, s0 + 0.05, s1 - 0.05, k),
                   AlignedPhone("S", s1 - 0.05, s1, k)]
        t += syl + gap
    out += 1e-4 * rng.standard_normal(n)
    return Audio(out.astype(np.float32), RATE), Alignment(words, phones, n / RATE)
