"""Words of other languages start where their sound does.

A word whose phones come from IPA (written ``/.../``, or read by eSpeak NG
for a line in another language) is aligned with the English acoustic model,
each phone by a stand-in (:mod:`..language.ipa`).  After silence such a word
starts where that model's silence gives up, which on words of 36 languages
(VoxAngeles, ``bench/languages.py``) is a median 17-19 ms before the
hand-labelled start of a vowel, nasal or voiced stop, and 50 ms after it for
a liquid; fewer than half of those starts lie within 20 ms.  The English
corrections do not carry over: a voiced stop moved to its release burst
(:mod:`.bursts`) loses the prevoicing that labellers count as part of it, and
the English offsets after silence (:mod:`.boundaries`) are offsets of English
sounds.

The word's first phone after silence (the clip's start, or a pause of
``onset.after_gap`` s) therefore starts at an acoustic landmark instead: the
first moment the level between ``onset.band`` Hz (25 ms Hann windows every
2 ms, the time of a window its centre) rises to ``onset.rise`` dB above the
quiet level (10th percentile) of the audio within 15 s (digital silence,
samples of zero, left out), or to ``onset.below_peak`` dB under its loud
level (99th percentile) if that is lower; a rise, from a window below that
level, not sound already there.  It is searched from ``onset.before`` s
before the aligned start (not before the previous word's end) to
``boundary.min_phone`` s before the phone's end; without a rise there the
aligned start stays.  A rise counts when the sound stays loud
``onset.sustain`` s (unset: at once).  The band leaves out the hum below
200 Hz and the hiss above 4 kHz that the silence of field recordings
carries, so voiced and voiceless sounds alike are found where they become
audible.  The settings are in ``data/timing.json``, chosen on half of
VoxAngeles' languages and checked on the other half: of the words' first
phones, 46-48 % started within 20 ms of the hand labels as aligned and
60-66 % with the English corrections; 80 % do on the tuning half and 68 % on
the other (within 40 ms: 91 and 89 %).

A fricative or affricate is also looked for where its hiss rises
(``onset.fricative``: the same rule over 2-8 kHz, 10 dB above that band's
own quiet level, loud for 40 ms so that a click is not taken for it,
searched from 0.3 s before): a sibilant holds little below 4 kHz, and the
aligner's silence takes in the start of it (VoxAngeles' "ʃa" began 150 ms
late).  That onset only moves the phone's start earlier, and the earlier of
the two counts.  Chosen on the same half of the languages, where settings
from 8 to 14 dB, 0.2 to 0.4 s and 1.5 to 3 kHz all scored within 0.1 point.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..audio import Audio
from ..pauses import settings
from .boundaries import boundary_class

#: Pronunciation sources whose phones come from IPA.
FROM_IPA = frozenset({"ipa", "espeak"})

_AROUND = 15.0
_DIGITAL_SILENCE = -100.0     # dB: below this a window holds (next to) nothing but zeros


def _settings() -> dict:
    return settings()["onset"]


def band_levels(samples: np.ndarray, rate: int, low: float, high: float, win: float,
                hop: float) -> np.ndarray:
    """Level in dB of ``samples`` between ``low`` and ``high`` Hz, in Hann
    windows of ``win`` s every ``hop`` s (the first window starts at sample 0)."""
    w, h = max(8, int(round(win * rate))), max(1, int(round(hop * rate)))
    if len(samples) < w:
        return np.zeros(0)
    nfft = max(256, 1 << (w - 1).bit_length())
    freqs = np.fft.rfftfreq(nfft, 1.0 / rate)
    keep = (freqs >= low) & (freqs < high)
    window = np.hanning(w)
    starts = np.arange(0, len(samples) - w + 1, h)
    out = np.empty(len(starts))
    for k0 in range(0, len(starts), 2048):       # bounded memory on long audio
        s = starts[k0:k0 + 2048]
        frames = samples[s[:, None] + np.arange(w)].astype(np.float64) * window
        spec = np.abs(np.fft.rfft(frames, nfft, axis=1)) ** 2
        out[k0:k0 + len(s)] = 10.0 * np.log10(spec[:, keep].sum(axis=1) / w + 1e-12)
    return out


def sound_onset(audio: Audio, start: float, end: float, cfg: dict | None = None,
                levels: np.ndarray | None = None) -> float | None:
    """The first time in [``start``, ``end``] at which the band level reaches
    the onset threshold (see the module docstring), or None.  ``levels``:
    the band levels of the whole clip (:func:`clip_levels`), when several
    onsets are looked for in it."""
    cfg = cfg or _settings()
    if end < start:
        return None
    rate = audio.rate
    win, hop = float(cfg.get("window", 0.025)), float(cfg.get("hop", 0.002))
    step = max(1, int(round(hop * rate)))
    w = max(8, int(round(win * rate)))
    first = max(0, int((start - _AROUND) * rate) // step * step)
    last = min(len(audio.samples), int((end + _AROUND) * rate))
    if levels is None:
        levels = band_levels(audio.samples[first:last], rate, *_band(cfg), win, hop)
    else:   # the windows lying wholly in [first, last), on the same grid
        levels = levels[first // step:max(first // step, (last - w) // step + 1)]
    # Digital silence (samples of zero, as an editor's gate leaves) is no measure of the room's quiet.
    heard = levels[levels > _DIGITAL_SILENCE]
    if not len(heard):
        return None
    threshold = min(float(np.percentile(heard, 10)) + float(cfg.get("rise", 20.0)),
                    float(np.percentile(heard, 99)) - float(cfg.get("below_peak", 10.0)))
    centres = first / rate + np.arange(len(levels)) * step / rate + win / 2
    loud = levels >= threshold
    # A rise: a loud window after a quiet one (sound already there at ``start`` has no onset there),
    # loud for ``sustain`` s (a click is not the sound's onset).
    rises = np.flatnonzero(loud[1:] & ~loud[:-1]) + 1
    hold = int(round(float(cfg.get("sustain", 0.0)) / hop))
    if hold > 1:
        run = np.convolve(loud.astype(int), np.ones(hold, int), "full")[hold - 1:]     # loud windows from each on
        rises = rises[run[rises] >= hold]
    rises = rises[(centres[rises] >= start) & (centres[rises] <= end)]
    return float(centres[rises[0]]) if len(rises) else None


def _band(cfg: dict) -> tuple[float, float]:
    low, high = cfg.get("band", (200.0, 4000.0))
    return float(low), float(high)


def clip_levels(audio: Audio, cfg: dict | None = None) -> np.ndarray:
    """The band levels of the whole clip, on the grid :func:`sound_onset` uses."""
    cfg = cfg or _settings()
    return band_levels(audio.samples, audio.rate, *_band(cfg), float(cfg.get("window", 0.025)),
                       float(cfg.get("hop", 0.002)))


def place_onsets(audio: Audio, result: list, estimated: list[bool], from_ipa: Sequence[bool]) -> None:
    """Start the first phone of every word of ``from_ipa`` that follows
    silence at its sound's onset, in place (the phone keeps its end and at
    least ``boundary.min_phone`` s).  ``result`` holds per word a list of
    (phone, start, end), or None; estimated words are left alone."""
    base = _settings()
    hiss = {**base, **base["fricative"]} if "fricative" in base else None
    keep = float(settings().get("boundary", {}).get("min_phone", 0.03))
    prev_end = None
    levels: dict[int, np.ndarray] = {}      # each band's levels of the clip, computed once, when first needed
    for wi, ph in enumerate(result):
        if not ph:
            continue
        p, a, b = ph[0]
        after_silence = prev_end is None or a - prev_end >= float(base["after_gap"])
        if from_ipa[wi] and after_silence and not estimated[wi]:
            found = []
            for k, cfg in enumerate([base] + ([hiss] if hiss and boundary_class(p) == "fricative" else [])):
                lo = max(a - float(cfg["before"]), prev_end or 0.0)
                if k not in levels:
                    levels[k] = clip_levels(audio, cfg)
                t = sound_onset(audio, lo, b - keep, cfg, levels[k])
                if t is not None and (k == 0 or t < a):
                    found.append(t)
            if found:
                ph[0] = (p, min(found), b)
        prev_end = ph[-1][2]
