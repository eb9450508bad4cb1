"""Words the speech has no room for: a wrong word in place of a shorter
spoken one ("elephant" in the transcript where the actor said "me").

The aligner gives each phone at least :data:`.model.SHORTEST_FRAMES`
frames, so a transcript word longer than the speech it stands for takes the
rest from its neighbours: the words beside it moved by 50-100 ms.  Such a
word has more than half of its phones squeezed to that length.  For each one,
:func:`room` makes a word pass over the words around it in which a loop of
any phones may take its place; where the loop does, over less time than the
word's phones need (:data:`ROOM`), or over more but still against a
strongly weighted word (:data:`STRICT`), the word is laid on the loop's
speech: the transcript is aligned again with the phones the loop heard
standing in for the word's, and :func:`lay_out` then spreads the word's own
phones over the time it got.
Words said as written fit their speech: on TIMIT's 61 sentences and the
reference clips of ``bench/alignment_accuracy.py``, no line changes.
"""

from __future__ import annotations

from collections.abc import Sequence

from ..audio import Audio
from .estimate import _estimate
from .loops import LOOP_WEIGHT, loop_pass
from .model import FRAME, SHORTEST_FRAMES, AlignedPhone, AlignSettings, Alignment, at_shortest, median_fit

#: A word with at least this many phones, more than half of them at the shortest length, is crowded
#: (the wrong words below have 57-100 % of them so; 23 of the 74 words said as written that the
#: fit lets through have exactly half).
CROWDED_PHONES = 4
#: ... when it fits its sound at least this much worse (per frame) than the line's median word.  A
#: wrong word in place of a shorter one: "elephant" for the middle word of TIMIT's sentences, 44 of
#: the 45 crowded ones 20 or more worse; "basketball" for "is" in the sample line, 22.  Crowded
#: words said as written (TIMIT, the MFA and voice-quality clips, each also sped up 1.5 times): 74
#: of 233 (at 40: 43 of 233, and 43 of the 45 wrong ones).
MISFIT = 20.0
#: The words on either side of a crowded word the pass holds.
AROUND = 3
#: The pass's beam (the default, 1e-200, costs twice as much and finds the same).
BEAM = 1e-60
#: The loop takes the word's place when it lasts under this share of the shortest the word's phones
#: can be.  Words said as written that are crowded have 0.67 or more (a fast "pretty": 0.67; on
#: TIMIT, 1.3 or more); "elephant" for a short word 0.14-1.8, half of them under 0.6.
ROOM = 0.6
#: A wrong word can also just fit the speech it stands for ("elephant" for "me": its phones need
#: 0.21 s, "me" took 0.22 s).  Over more than ROOM, the loop takes the word's place where it still
#: does with this grammar weight against the word's (1 - it), the acoustic evidence the loop must
#: have over the word.  No crowded word said as written takes a loop on TIMIT's 61 sentences or
#: the reference clips at 1e-30; at 1e-25, a fast "pretty" does; at 1e-35, 36 of 48 "elephant"s
#: for a short word still do.
STRICT = 1e-30
#: ... and where that loop lies within the word's aligned time, give or take this (s): a loop
#: further out has taken speech a wrong word beside it left over ("won't" after "blue" for "thinking").
INSIDE = 0.1


def crowded(al: Alignment) -> list[int]:
    """Transcript indices of the spoken words of ``al`` that have at least
    :data:`CROWDED_PHONES` phones, more than half of them at the shortest
    length, and that fit their sound :data:`MISFIT` worse than the line's
    median word (:func:`.model.median_fit`): fast speech squeezes words said
    as written too, but they still fit their sound."""
    script = al.script
    squeezed = [0] * len(script)
    count = [0] * len(script)
    for k, p in al.script_phones():
        if not p.estimated:
            count[k] += 1
            squeezed[k] += at_shortest(p.end - p.start)
    return [k for k, w in enumerate(script)
            if w.spoken and not w.estimated and count[k] >= CROWDED_PHONES and 2 * squeezed[k] > count[k]
            and w.fit is not None and (median_fit(script, {k}) or 0.0) - w.fit >= MISFIT]


def room(snd: Audio, al: Alignment, prons: Sequence[Sequence[str]],
         settings: AlignSettings) -> dict[int, list[str]]:
    """{transcript index: the phones heard in its place} for the crowded
    words of ``al`` (aligned to ``snd``) whose speech a loop of any phones
    takes, over well under the time the word's own phones need (:data:`ROOM`),
    or, over more, against a word weighed :data:`STRICT` times the loop's and
    inside the time the word got (:data:`INSIDE`)."""
    script = al.script
    n = len(prons)
    if len(script) != n:
        return {}
    out = {}
    for k in crowded(al):
        first, last = max(0, k - AROUND), min(n - 1, k + AROUND)
        t0 = script[first].start if first > 0 else 0.0
        t1 = script[last].end if last < n - 1 else snd.duration
        window = (snd, prons[first:last + 1], first, k - first, settings, t0, t1)
        loop = _loop_in_place(*window, LOOP_WEIGHT)
        if loop and loop[-1][2] - loop[0][1] >= ROOM * SHORTEST_FRAMES * len(prons[k]) * FRAME:
            loop = _loop_in_place(*window, STRICT)
            if loop and (loop[0][1] < script[k].start - INSIDE or loop[-1][2] > script[k].end + INSIDE):
                loop = []
        if loop:
            out[k] = [p for p, _, _ in loop]
    return out


def _loop_in_place(snd: Audio, prons: Sequence[Sequence[str]], first: int, k: int, settings: AlignSettings,
           t0: float, t1: float, weight: float) -> list[tuple[str, float, float]]:
    """The (phone, start s, end s) of the loop a word pass over ``prons``
    (tokens from ``w<first>``) takes in place of word ``k`` (the grammar's
    weight of the loop ``weight``); none where the word keeps its place."""
    segs = loop_pass(snd, prons, first, set(), settings, t0, t1, beam=BEAM, instead=frozenset({k}), weight=weight)
    return [(w[1:], a, b) for w, a, b in segs or [] if w.startswith("x")]


def lay_out(al: Alignment, own: dict[int, Sequence[str]]) -> None:
    """Give the words ``own`` (transcript index: phones) of ``al``, aligned
    with other phones standing in for theirs (:func:`room`), their own
    phones, spread over the time each got; in place.  ``al`` holds the
    transcript's words alone (before the check of the take)."""
    phones = [p for p in al.phones if p.word_index not in own]
    for k, ph in own.items():
        w = al.words[k]
        w.phones = list(ph)
        phones += [AlignedPhone(p, a, b, k) for p, a, b in _estimate([list(ph)], [(w.start, w.end)])[0]]
    al.phones = sorted(phones, key=lambda p: (p.word_index, p.start))
