"""Vowels held for seconds and said otherwise than the dictionary says.

A drawn-out vowel ("Mooontreal", three seconds of it) is aligned by its
sound, and over seconds a small difference of quality outweighs the rest of
the line: where the speaker's vowel is not the dictionary's (the open vowels
of "lot", "strut" and "thought" differ from accent to accent), the aligner
gives the held sound to another vowel of the word that fits it better,
squeezes the phones before it and leaves the word's own later sounds
uncovered, as silence.  The mouth then rests through speech.

When the first alignment of a line holds a vowel half a second long (and
five times the line's median phone: :func:`.edges.stretched`) in a word next to which
it leaves at least :data:`UNCOVERED` s of speech off its words (a
hesitation's drawn-out "uh" aside), :func:`said_otherwise` aligns
the line again with each vowel of the words holding one free to be another
of its group (``data/assimilation.json``, ``held``), one vowel at a time,
and keeps that alignment where it lays the words on that much more of the
speech.  Lines without a held vowel cost nothing more, and takes longer
than :data:`LONGEST` are left as they are.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Sequence

import numpy as np

from ..audio import Audio
from ..language.assimilation import held_alike
from .boundaries import boundary_class
from .edges import stretched
from .model import FRAME, Alignment, Variants
from .speech import covered_by, frame_levels, runs, speech_mask
from .verify import WORD_MARGIN

#: Speech (s) the first alignment leaves off its words for the line to be aligned again, and how much
#: more of it the second alignment must lay its words on to be kept.
UNCOVERED = 0.3
#: Speech within this much (s) of a word is the word's (as for the check of the take).
MARGIN = WORD_MARGIN
#: The speech left off lies next to the word holding the vowel: it starts within this much (s) of the
#: word's end, or ends within it of the word's start (beyond MARGIN).
NEXT_TO = 0.1
#: Clips longer than this (s) are not aligned again: a long take is aligned window by window
#: (:attr:`.model.AlignSettings.stream_above`), and aligning all of it twice for one word would
#: double its time.
LONGEST = 90.0


def held_words(al: Alignment) -> list[int]:
    """Transcript indices of the spoken words of ``al`` aligned
    acoustically that hold a vowel as long as :func:`.edges.stretched` finds
    (:data:`.edges.STRETCHED` s and :data:`.edges.SLOWER_THAN` times the
    line's median phone; hesitations, drawn out by nature, left out)."""
    script = al.script
    return sorted({k for k, p in stretched(al) if boundary_class(p.phone) == "vowel" and not p.estimated
                   and script[k].spoken and not script[k].estimated})


def uncovered(al: Alignment, mask: np.ndarray) -> np.ndarray:
    """[start, end) frames of the runs of speech (``mask``, one flag a frame)
    more than :data:`MARGIN` from every spoken word of ``al``."""
    return runs(mask & ~covered_by(al.words, len(mask), MARGIN))


def _seconds(spans: np.ndarray) -> float:
    return float((spans[:, 1] - spans[:, 0]).sum()) * FRAME if len(spans) else 0.0


def next_to(al: Alignment, words: list[int], spans: np.ndarray) -> list[int]:
    """The ``words`` (transcript indices) of ``al`` beside which a run of
    ``spans`` (frames) :data:`UNCOVERED` s long starts or ends."""
    near = (MARGIN + NEXT_TO) / FRAME
    long = [(i, j) for i, j in spans.tolist() if (j - i) * FRAME >= UNCOVERED]
    script = al.script
    return [k for k in words
            if any(abs(i - script[k].end / FRAME) <= near or abs(script[k].start / FRAME - j) <= near for i, j in long)]


def widened(phones: Sequence[str], alike: dict[str, tuple[str, ...]]) -> Variants:
    """``phones`` (with the other pronunciations they have) and, for each of
    its vowels in a group of ``alike``, the word with that vowel said as each
    other of its group."""
    have = [list(v) for v in getattr(phones, "variants", [])]
    shown = [list(v) for v in getattr(phones, "shown", have)]
    for i, p in enumerate(phones):
        for q in alike.get(p, ()):
            v = list(phones[:i]) + [q] + list(phones[i + 1:])
            if v not in have and v != list(phones):
                have.append(v)
                shown.append(v)
    return Variants(list(phones), have, shown)


def said_otherwise(snd: Audio, al: Alignment, phones: Sequence[Sequence[str]],
                   realign: Callable[[dict[int, Variants]], Alignment],
                   own: Collection[int] | None = None) -> tuple[Alignment, dict[int, Variants]]:
    """(the alignment to keep, {transcript index: the phones its word is to be
    aligned with from now on}) for the first alignment ``al`` of ``phones``
    to ``snd``; ``realign`` aligns the line with some words' phones in place
    of theirs.  ``al`` and nothing where no word holds a vowel next to
    :data:`UNCOVERED` s of speech left off the words, or a second alignment
    lays its words on no more of the speech.  Only the words ``own`` (None:
    all) may be said otherwise: those aligned with the phones they show, not
    with stand-ins for another language's sounds."""
    words = [k for k in held_words(al) if own is None or k in own] if snd.duration <= LONGEST else []
    if not words:
        return al, {}
    mask, _ = speech_mask(frame_levels(snd), snd)
    spans = uncovered(al, mask)
    words = next_to(al, words, spans)
    if not words:
        return al, {}
    before = _seconds(spans)
    alike = held_alike()
    wider = {k: widened(phones[k], alike) for k in words}
    wider = {k: v for k, v in wider.items() if len(v.variants) > len(getattr(phones[k], "variants", []))}
    if not wider:
        return al, {}
    second = realign(wider)
    if _seconds(uncovered(second, mask)) <= before - UNCOVERED:
        return second, wider
    return al, {}
