"""Stops after silence start at their release burst.

A stop consonant is a closure (silent, or voiced low in the throat) and then
a burst, a short broadband noise as the lips or tongue let go.  Between
words the closure is part of the stop; after a pause or at the start of a
clip it cannot be told from the silence, and listeners (and hand labels)
hear the stop begin at its burst.  pocketsphinx starts such a stop wherever
its silence model gives up, often tens of milliseconds early (on the
prevoicing of /b d g/, or at the clip's very first frame).

:func:`refine_stops` moves the start of such a stop to its burst: the
largest rise of the energy above ``burst.band`` Hz inside the stop's
interval, when that rise is at least ``burst.min_rise`` dB.  The settings
are in ``data/timing.json``.  Words of other languages, whose phones come
from IPA, are left to :mod:`.onsets`: their voiced stops are often prevoiced,
and the prevoicing belongs to the stop.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..audio import Audio
from ..pauses import settings

STOPS = frozenset({"B", "D", "G", "P", "T", "K"})


def _settings() -> dict:
    return settings()["burst"]


def band_levels(samples: np.ndarray, rate: int, band: float, win: float, hop: float) -> np.ndarray:
    """Level in dB of ``samples`` above ``band`` Hz, in Hann windows of
    ``win`` s every ``hop`` s (the first window starts at sample 0)."""
    w, h = max(8, int(round(win * rate))), max(1, int(round(hop * rate)))
    if len(samples) < w:
        return np.zeros(0)
    starts = np.arange(0, len(samples) - w + 1, h)
    frames = samples[starts[:, None] + np.arange(w)].astype(np.float64) * np.hanning(w)
    nfft = max(256, 1 << (w - 1).bit_length())
    spec = np.abs(np.fft.rfft(frames, nfft, axis=1)) ** 2
    high = spec[:, np.fft.rfftfreq(nfft, 1.0 / rate) >= band].sum(axis=1)
    return 10.0 * np.log10(high / w + 1e-12)


def burst_time(audio: Audio, start: float, end: float, cfg: dict | None = None) -> float | None:
    """The time of the strongest release burst between ``start`` and
    ``end`` (s), or None if no rise reaches ``min_rise`` dB."""
    cfg = cfg or _settings()
    rate = audio.rate
    win, hop, span = cfg["window"], cfg["hop"], cfg["rise_over"]
    a = max(0, int(round((start - win) * rate)))
    b = min(len(audio.samples), int(round((end + win) * rate)))
    levels = band_levels(audio.samples[a:b], rate, cfg["band"], win, hop)
    k = max(1, int(round(span / hop)))
    if len(levels) <= k:
        return None
    # rise[i]: how much louder window i + k is than window i; the burst is
    # put where window i + k starts.
    rise = levels[k:] - levels[:-k]
    t = a / rate + (np.arange(len(rise)) + k) * hop
    inside = (t >= start) & (t < end)
    if not inside.any():
        return None
    i = int(np.argmax(np.where(inside, rise, -np.inf)))
    if rise[i] < cfg["min_rise"]:
        return None
    return float(t[i])


def refine_stops(audio: Audio, result: list, estimated: list[bool],
                 from_ipa: Sequence[bool] | None = None) -> None:
    """Move the start of every word-initial stop that follows silence (the
    clip's start, or a gap of ``burst.after_gap`` s or more) to its release
    burst, in place (the burst may lie up to ``burst.slack`` s past the
    stop's end; the stop keeps at least ``burst.min_keep`` s).  ``result``
    holds per word a list of (phone, start, end), or None; estimated words
    are left alone, and so are the words of ``from_ipa`` (phones read from
    IPA, of other languages, whose voiced stops are often prevoiced and
    whose start :func:`.onsets.place_onsets` finds)."""
    cfg = _settings()
    prev_end = 0.0
    first = True
    for wi, ph in enumerate(result):
        if not ph:
            continue
        p, a, b = ph[0]
        after_silence = first or a - prev_end >= cfg["after_gap"]
        other = from_ipa is not None and from_ipa[wi]
        if p in STOPS and after_silence and not estimated[wi] and not other and b - a > cfg["min_keep"]:
            t = burst_time(audio, a, b + cfg["slack"], cfg)
            if t is not None and t > a:
                ph[0] = (p, min(t, b - cfg["min_keep"]), b)
        first = False
        prev_end = ph[-1][2]
