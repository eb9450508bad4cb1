"""Phone boundaries corrected by the classes of the two phones they join.

pocketsphinx places a boundary on its 10 ms frame grid, at the first frame
of the new phone; a frame's 25 ms window is centred some 8-13 ms after the
frame's time, so its boundaries lie early on average (7.5 ms, measured
against hand-labelled read English, TIMIT), and the bias depends on the
sounds on either side: a vowel before a fricative, nasal or stop ends
10-15 ms early, a glide after a consonant starts 15-45 ms early, and the
first phone of a clip that opens with silence starts 25-55 ms early (the
silence model gives up before the voice starts).  Boundary correction by
phone context is the standard remedy of HMM aligners.

Aligners of the same kind carry the same bias.  The references of the MFA
clips in ``bench/alignment_accuracy.py`` were made by the Montreal Forced
Aligner, on the same 10 ms grid: the uncorrected boundaries lie a median -5 to
+15 ms from them for every common pair of classes, where TIMIT's hand labels
put the same pairs 7-12 ms early.  Corrected, the boundaries lie a median
5 ms after those references, and fewer fall within 20 ms of them (83 % to
77 %); most of that is the references' grid (a start 5 ms off it is 15 or
25 ms from a reference 20 ms away; within 25 ms: 84 % to 83 %).  The
hand-labelled praatio sentences side with TIMIT (71 % to 83 % within 20 ms).
Giving the MFA clips back their figure costs TIMIT's held-out speakers theirs:
offsets in 10 ms steps give the clips 78 % and TIMIT 81.0 % (not 81.9 %);
no offset where it gains fewer than two of the 870 development starts, 78 %
and 81.5 %; offsets tuned with the clips' figure in the aim, 81-82 % and
80 %, under 95 % within 40 ms.

:func:`shift_boundaries` moves every boundary by the offset of its pair of
classes, ``boundary.shift["<before>><after>"]`` in ``data/timing.json``
(``boundary.default`` for a pair the table does not name).  The classes are
``start`` (the clip's first phone: nothing before it), ``gap`` (a phone after
a pause inside the clip), ``vowel``, ``plosive``, ``fricative`` (affricates
and /h/ included), ``nasal``, ``liquid`` (/l r/) and ``glide`` (/w y/).  The
offsets are the ones that put the most boundaries within 20 ms of the hand
labels (then within 40 ms) on four TIMIT speakers (the development half of
``bench/timit.py``), in steps of 5 ms, for the pairs seen at least five times
there (a nasal after a fricative or a stop, three and four times, shares one
offset: 20 ms).  Every phone keeps at least ``boundary.min_phone`` s (30 ms: the
decoder's own shortest phone, three 10 ms states).  The clip's first phone
moves no later than the voice onset: the first moment the level (25 ms
windows every 5 ms) is ``boundary.onset_rise`` dB above the quiet level
(10th percentile) of the audio within 15 s of it, or
``boundary.onset_below_peak`` dB below its loud level (99th percentile) if
that is lower (audio with no pause), so a clip cut tight on its first word
keeps its start.

A /t/ run straight into /p b m/ (``boundary.unreleased``: "it pays",
"atmosphere", "that man") is unreleased or glottal in running speech and its
closure is silent, so the lips close for the labial while the tongue holds
the /t/ (TIMIT's labellers often mark a glottal stop there, or no /t/ at all).  Such a /t/ keeps
its aligned start and lasts ``min_phone``; the labial starts there, and no
offset moves either boundary (the 35 ms of ``plosive>plosive`` would close
the lips late).  On the development speakers this holds for /t/ only: /d/
(its closure voiced and heard) and /k/ before a labial fare worse with it.

A phone of a word read from IPA (another language, or a word written
``/.../``) takes its offset from ``boundary_ipa.shift`` instead: the English
offsets but for four pairs, and none for the word's first phone after
silence, which :mod:`.onsets` places.  The four were chosen on VoxAngeles
(``bench/languages.py``) by tuning each half of its languages alone (5 ms
steps, pairs seen 20 times, a step kept when it gains two starts) and keeping
the changes both halves made, at the smaller size: a vowel ends 5 ms earlier
before a stop and 5 ms later before a nasal, a glide ends 10 ms later before
a vowel, and a vowel after a vowel starts 10 ms earlier.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..audio import Audio
from ..language.phonemes import MANNER
from ..pauses import settings
from .speech import frame_levels

_CLASS = {"affricate": "fricative"}
_HOP = 0.005
_WIN = 0.025
_AROUND = 15.0


def boundary_class(phone: str | None, first: bool = False) -> str | None:
    """The class a boundary offset is looked up by.  ``phone`` None is no
    phone before the boundary: ``start`` when ``first`` (the clip's first
    phone), else ``gap``; None for a phone outside the inventory."""
    if phone is None:
        return "start" if first else "gap"
    if phone in ("W", "Y"):
        return "glide"
    manner = MANNER.get(phone)
    if manner is None or manner == "silence":
        return None
    return _CLASS.get(manner, manner)


def voice_onset(audio: Audio, start: float, end: float, rise: float, below_peak: float = 10.0) -> float:
    """The first time in [``start``, ``end``] at which the level is ``rise``
    dB above the quiet level (10th percentile) of the audio within 15 s of
    that span, or within ``below_peak`` dB of its loud level (99th
    percentile) where it has no quiet part; ``end`` if none."""
    # The levels of the clip's stretch around the phone (at most _AROUND s either side) are enough.
    step = int(round(_HOP * audio.rate))
    first = max(0, int((start - _AROUND) * audio.rate) // step * step)
    last = min(len(audio.samples), int((end + _AROUND) * audio.rate))
    levels = frame_levels(Audio(audio.samples[first:last], audio.rate), _HOP)
    threshold = min(float(np.percentile(levels, 10)) + rise, float(np.percentile(levels, 99)) - below_peak)
    centres = first / audio.rate + np.arange(len(levels)) * _HOP + _WIN / 2
    loud = np.flatnonzero((centres >= start - _HOP / 2) & (centres <= end) & (levels >= threshold))
    if not len(loud):
        return end
    k = int(loud[0])
    # A loud window that was open at ``start`` already: the voice is there.
    return float(start if centres[k] - _WIN / 2 <= start else max(start, centres[k]))


def _settings() -> dict:
    return settings().get("boundary", {})


def _unreleased(result: list, estimated: list[bool], stops: set[str], labials: set[str]) -> set[tuple[int, int]]:
    """(word, index) of every phone of ``stops`` that runs straight into a
    phone of ``labials``, neither placed by estimate."""
    seq = [(wi, k, p, a, b) for wi, ph in enumerate(result) if ph and not estimated[wi]
           for k, (p, a, b) in enumerate(ph)]
    return {(w0, k0) for (w0, k0, p, _a, b), (_w1, _k1, q, c, _d) in zip(seq, seq[1:])
            if p in stops and q in labials and abs(b - c) < 1e-6}


def shift_boundaries(audio: Audio, result: list, estimated: list[bool], cfg: dict | None = None,
                     from_ipa: Sequence[bool] | None = None, ipa_cfg: dict | None = None) -> None:
    """Move each phone's start (and the end of the phone before it, when
    that phone ends there) by the offset of its class pair, in place; a
    /t/ run into /p b m/ lasts ``min_phone`` and the lips close after it.

    ``result`` holds per word a list of (phone, start, end), or None; phones
    of words placed by estimate are left alone, and so is a boundary with
    such a phone on either side.  A phone of a word of ``from_ipa`` takes
    its offset from ``ipa_cfg`` (default: ``boundary_ipa`` of the timing
    settings)."""
    cfg = _settings() if cfg is None else cfg
    table = {str(k): float(v) for k, v in cfg.get("shift", {}).items()}
    default = float(cfg.get("default", 0.0))
    offsets = {False: (table, default)}
    if from_ipa is not None and any(from_ipa):
        ipa_cfg = settings().get("boundary_ipa", {}) if ipa_cfg is None else ipa_cfg
        offsets[True] = ({str(k): float(v) for k, v in ipa_cfg.get("shift", {}).items()},
                         float(ipa_cfg.get("default", 0.0)))
    keep = float(cfg.get("min_phone", 0.03))
    unreleased = cfg.get("unreleased", {})
    held = _unreleased(result, estimated, set(unreleased.get("stops", ())), set(unreleased.get("before", ())))
    if not any(t or d for t, d in offsets.values()) and not held:
        return
    before = None      # (word, index) of the phone seen last, None when it was estimated
    prev_end = None    # where the phone seen last ends (None: no phone yet)
    for wi, ph in enumerate(result):
        if not ph:
            continue
        for k, (p, a, b) in enumerate(ph):
            if estimated[wi]:
                before, prev_end = None, b
                continue
            joined = prev_end is not None and abs(prev_end - a) < 1e-6
            if joined and before is None:      # an estimated phone ends here
                prev_end = b
                continue
            prev = result[before[0]][before[1]] if joined else None
            if (wi, k) in held:
                start = a              # the unreleased stop keeps its aligned start ...
            elif joined and before in held:
                start = min(a, prev[1] + keep)      # ... and the lips close ``keep`` after it
            else:
                shift, fallback = offsets[bool(from_ipa is not None and from_ipa[wi])]
                start = _shifted(audio, p, a, b, prev, prev_end, shift, fallback, keep, cfg)
            if start != a:
                ph[k] = (p, start, b)
                if prev:
                    result[before[0]][before[1]] = (prev[0], prev[1], start)
            before, prev_end = (wi, k), b


def _shifted(audio: Audio, p: str, a: float, b: float, prev: tuple | None, prev_end: float | None,
             table: dict[str, float], default: float, keep: float, cfg: dict) -> float:
    """Where the phone ``p`` aligned at [``a``, ``b``] starts after its
    pair's offset (``prev``: the phone joined to it, None after a pause or at
    the clip's start)."""
    left = boundary_class(prev[0] if prev else None, first=prev_end is None)
    right = boundary_class(p)
    off = table.get(f"{left}>{right}", default) if left and right else 0.0
    if not off:
        return a
    # Neither phone may shrink below ``keep``, nor a phone after a pause cross it;
    # a boundary these limits would move against its offset stays.
    lo = prev[1] + keep if prev else (prev_end if prev_end is not None else 0.0)
    start = min(max(a + off, lo), b - keep)
    if left == "start" and start > a:
        start = min(start, voice_onset(audio, a, b - keep, float(cfg.get("onset_rise", 20.0)),
                                       float(cfg.get("onset_below_peak", 10.0))))
    return start if (start - a) * off > 0 else a
