"""Speech before the transcript's first word or after its last (a slate or an
actor's ad-lib before the line, an ad-lib after it, the next line left in
the same take), and speech it leaves out between two words (a cut line).

A forced alignment must lay the whole transcript over the whole clip, so
such speech pulls the script's first or last words over it: they were
stretched or moved by seconds, and their own speech was taken for
unscripted speech.  When the first alignment shows it (the check of the
take, :mod:`.verify`, found unscripted speech, or a word at either edge
holds a phone :data:`STRETCHED` s long in which words are heard),
:func:`script_bounds` makes one
more word pass whose grammar lets a loop of any phones take the start and
the end of the clip.  :func:`edges` keeps what that pass says where it
moves the script's edge: the caller aligns the transcript to the clip
between the two, and checks the take again over the whole clip.

Speech left out between two words pulls the words around it over it in the
same way: :func:`left_out` finds it with a loop allowed between the words
around it, and the caller aligns the transcript with it silenced.
"""

from __future__ import annotations

from collections.abc import Collection, Sequence

import numpy as np

from ..audio import Audio
from .fillers import base_token, is_hesitation
from .loops import loop_pass, loops
from .model import FRAME, AlignedPhone, AlignSettings, Alignment
from .speech import frame_levels, speech_mask
from .verify import edit_path, words_heard

#: A loop takes at least this much (s) for the script's edge to move.
MIN_LOOP = 0.4
#: Clips longer than this (s) are not searched this way (one pass holds the whole clip).
MAX_CLIP = 90.0
#: A phone this long (s) in a word at either edge of the first alignment shows the word pulled ...
STRETCHED = 0.5
#: ... when it is also this many times the line's median phone (very slow speech, 0.2 s a phone and
#: more, holds phones over 0.5 s of its own; a line's phones run 0.06-0.1 s at a usual pace).
SLOWER_THAN = 5.0
#: The words at either edge that are looked at for it.
EDGE_WORDS = 3
#: An edge moves only by more than this (s).
SHIFT = 0.1
#: Speech after the script pulls its last few words: a new end moves at most this many (speech cut
#: from the middle of a transcript leaves its last words at the clip's end, where the loop may take
#: them too).
MAX_MOVED = 3
#: The words a new end moves are heard at the clip's end in this share of their phones: they were
#: said there, and the first alignment stands.
HEARD = 0.5
#: Room (s) left beyond the script's edge, and how much further (s) it may reach, to the next pause.
MARGIN, REACH = 0.1, 0.3
#: Speech left out between the script's words (:func:`left_out`): the words on either side of the
#: unscripted speech found between which the loop may come, and the words further out the pass
#: holds without one (the words next to a cut may have been pulled far from their own speech).
AROUND, CONTEXT = 3, 3
#: That pass's beam, and the edges' pass's (:func:`script_bounds`): the default (1e-200) costs five
#: times as much with the loop at several gaps, and finds the same loops on TIMIT sentences (and the
#: same speech before and after the script on bench/offscript.py's 15 pairs of them).
GAP_BEAM = 1e-60
#: That pass's penalty for each phone of the loop: weaker than at the edges, as a cut line is one
#: long loop whose every phone pays it; the words around the cut otherwise take the cut speech
#: again (MFA clips, ten words cut: 53-88 % of their speech found at 1e-2, 18-84 % at 1e-3).
GAP_PENALTY = 1e-2
#: The search for speech left out is made at most this many times: a second time on the take
#: realigned with the first one's loops silenced, for a second cut (two lines cut close together
#: share one pass, which holds one loop).
CUT_ROUNDS = 2


def script_bounds(audio: Audio, prons: Sequence[Sequence[str]],
                  settings: AlignSettings) -> tuple[float | None, float | None]:
    """(where the first of the words ``prons`` starts, where the last ends)
    when any speech may come before and after them; each None where nothing
    does (or the clip is too long, or the pass fails)."""
    if not prons or audio.duration > MAX_CLIP:
        return None, None
    segs = loop_pass(audio, prons, 0, {0, len(prons)}, settings, beam=GAP_BEAM)
    if segs is None:
        return None, None
    known = {f"w{i}" for i in range(len(prons))}
    at = [k for k, (w, _, _) in enumerate(segs) if base_token(w) in known]
    before, after = loops(segs[:at[0]]), loops(segs[at[-1] + 1:])
    start = segs[at[0]][1] if before and before[0][1] - before[0][0] >= MIN_LOOP else None
    end = segs[at[-1]][2] if after and after[0][1] - after[0][0] >= MIN_LOOP else None
    return start, end


def stretched(al: Alignment, held: Collection[int] = ()) -> list[tuple[int, AlignedPhone]]:
    """(index in ``al.script``, phone) for the phones :data:`STRETCHED` s long or more, and
    :data:`SLOWER_THAN` times the line's median phone, in the transcript's words (hesitations,
    often drawn out, left out; and the words ``held``, whose held vowel was found to be their own,
    :mod:`.held`): a line said slowly all through holds long phones of its own."""
    script = al.script
    phones = al.script_phones()
    if not phones:
        return []
    longest = max(STRETCHED, SLOWER_THAN * float(np.median([p.end - p.start for _, p in phones])))
    return [(k, p) for k, p in phones
            if p.end - p.start >= longest and not is_hesitation(script[k].text) and k not in held]


def _pulled(snd: Audio, al: Alignment, settings: AlignSettings, held: Collection[int] = ()) -> bool:
    """Whether the first alignment shows the script pulled at an edge: the
    check of the take found unscripted speech, or a word at either edge holds
    a phone :data:`STRETCHED` s long in which words are heard (a vowel held
    at the end of a line is heard as one word at most, and costs no pass)."""
    if al.unscripted:
        return True
    script = [k for k, w in enumerate(al.script) if w.spoken and not is_hesitation(w.text)]
    edge = set(script[:EDGE_WORDS] + script[-EDGE_WORDS:])
    long = [(p.start, p.end) for k, p in stretched(al, held) if k in edge]
    return any(words_heard(snd, long, settings)) if long else False


def edges(snd: Audio, al: Alignment, prons: Sequence[Sequence[str]],
          settings: AlignSettings, held: Collection[int] = ()) -> tuple[float, float] | None:
    """(start, end) s of the stretch of ``snd`` the transcript is to be
    aligned to, when speech before or after it pulled its first or last
    words in the first alignment ``al``; None to keep ``al``.  The long
    phones of the words ``held`` (a held vowel found to be the word's own,
    :mod:`.held`) are not taken for a pull."""
    script = [w for w in al.script if w.spoken]
    if not script or not _pulled(snd, al, settings, held):
        return None
    start, end = script_bounds(snd, prons, settings)
    if start is not None and start < script[0].start + SHIFT:
        start = None
    if end is not None and (end > script[-1].end - SHIFT or
                            sum(w.end > end + SHIFT for w in script) > MAX_MOVED):
        end = None
    if start is None and end is None:
        return None
    mask, _ = speech_mask(frame_levels(snd), snd)
    if start is not None:    # a loop may take a word's first sound: back to the pause before, within REACH
        first = min(len(mask) - 1, int(round(start / FRAME)))
        pause = [k for k in range(first, max(-1, first - int(round(REACH / FRAME))), -1) if not mask[k]]
        start = max(0.0, (pause[0] + 1) * FRAME - MARGIN if pause else start - REACH)
    if end is not None:      # or its fading end: on to the next pause, within REACH
        first = int(round(end / FRAME))
        pause = [k for k in range(first, min(len(mask), first + int(round(REACH / FRAME)))) if not mask[k]]
        end = min(snd.duration, pause[0] * FRAME + MARGIN if pause else end + REACH)
    return (start or 0.0), (end if end is not None else snd.duration)


def said_at_the_end(first: Alignment, again: Alignment, end: float) -> bool:
    """Whether the words a new ``end`` moves are heard at the end of the
    clip after all: :data:`HEARD` of their phones matched, in order, by the
    last phones recognised there (twice as many)."""
    moved = [p for w in first.script if w.spoken and w.end > end + SHIFT for p in w.phones]
    heard = [p for w in again.words if w.recognized and w.start >= end for p in w.phones][-2 * len(moved):]
    if not moved or not heard:
        return False
    return sum(same for _, _, same in edit_path(moved, heard)) >= HEARD * len(moved)


def left_out(snd: Audio, al: Alignment, prons: Sequence[Sequence[str]], settings: AlignSettings,
             known: Sequence[tuple[float, float]] = (), held: Collection[int] = ()) -> list[tuple[float, float]]:
    """(start, end) s of the speech the transcript leaves out between its
    words (a cut line, an ad-lib), when the check of the take (:mod:`.verify`)
    found unscripted speech there in the alignment ``al``, or a word there
    holds a phone :data:`STRETCHED` s long.

    Such speech pulls the words around it over it, so the unscripted speech
    found lies near it, not on it.  A word pass over the words around each
    such stretch (:data:`AROUND` on either side) lets one loop of any phones
    come between two of them (a cut is one stretch: with a loop allowed at
    every gap, words of the script are taken for words said in the cut
    speech, and placed there between two loops); where the stretches are
    close enough to share a pass and it finds no path, each is passed
    alone.  The loops of :data:`MIN_LOOP` s or more in which words are heard
    are returned, for the caller to align the transcript with them silenced
    and check the take again; unscripted speech on the stretches ``known``
    (found before, and silenced in ``snd``) is not looked around again, nor
    the long phones of the words ``held`` (:func:`edges`)."""
    script = al.script
    n = len(prons)
    if len(script) != n or n < 2 or snd.duration > MAX_CLIP:
        return []
    said = [k for k, w in enumerate(script) if w.spoken]
    centres = []        # the gaps (before word k) the speech left out is looked for around
    for start, end, _ in al.unscripted:
        if any(start < b and a < end for a, b in known):
            continue
        before = sum(script[k].end <= start + SHIFT for k in said)
        if 0 < before < len(said):      # words on both sides: not speech before or after the script
            centres.append(said[before - 1] + 1)
    # A word pulled over it all (no speech left uncovered): one long phone, where words are heard
    # (not a held vowel).
    long = [(k, p) for k, p in stretched(al, held) if 0 < k < n - 1]
    for (k, p), heard in zip(long, words_heard(snd, [(p.start, p.end) for _, p in long], settings)):
        if heard:
            centres.append(k + 1 if p.end > (script[k].start + script[k].end) / 2 else k)
    # The gaps around each centre (lo..hi); those that overlap make one window, passed at once.
    windows: list[list[tuple[int, int]]] = []
    for g in sorted(set(centres)):
        lo, hi = max(1, g - AROUND), min(n - 1, g + AROUND)
        if windows and lo <= max(h for _, h in windows[-1]):
            windows[-1].append((lo, hi))
        else:
            windows.append([(lo, hi)])
    out = []
    for parts in windows:
        segs = _one_loop(snd, al, prons, settings, parts[0][0], max(h for _, h in parts))
        if segs is None and len(parts) > 1:
            # No path through the whole window (a hard voice, where a loop fits any speech better
            # than the words and their path falls out of the beam): each centre's gaps alone.
            segs = [sg for lo, hi in parts for sg in _one_loop(snd, al, prons, settings, lo, hi) or []]
        out += [(a, b) for a, b in loops(segs or []) if b - a >= MIN_LOOP]
    spans = sorted(set(out))
    return [span for span, heard in zip(spans, words_heard(snd, spans, settings)) if heard]


def _one_loop(snd: Audio, al: Alignment, prons: Sequence[Sequence[str]], settings: AlignSettings,
              lo: int, hi: int) -> list[tuple[str, float, float]] | None:
    """The segments of a word pass over the words around the gaps before
    words ``lo``..``hi`` of the transcript, one loop of any phones at one of
    those gaps; None where it finds no path."""
    script, n = al.script, len(prons)
    # The words the pass holds: CONTEXT more on either side of the gaps, as the words next to
    # the gaps may have been pulled far from their own speech; from the clip's start or to its end.
    first, last = max(0, lo - CONTEXT), min(n - 1, hi - 1 + CONTEXT)
    t0 = script[first].start if first > 0 else 0.0
    t1 = script[last].end if last < n - 1 else snd.duration
    return loop_pass(snd, prons[first:last + 1], first, set(range(lo - first, hi - first + 1)), settings,
                     t0, t1, beam=GAP_BEAM, one=True, penalty=GAP_PENALTY)


def heard_in(al: Alignment, spans: list[tuple[float, float]]) -> bool:
    """Whether the speech left out (``spans``, from :func:`left_out`) is
    heard as words in the alignment ``al`` made with it silenced: at least
    :data:`HEARD` of it lies in ``al.unscripted``.  Otherwise the loops took
    the script's own speech (a held vowel), and the first alignment stands."""
    inside = sum(max(0.0, min(b, e) - max(a, s)) for a, b in spans for s, e, _ in al.unscripted)
    return inside >= HEARD * sum(b - a for a, b in spans)
