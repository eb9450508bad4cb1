"""Clips of 10 to 90 s: cut at pauses into an even number of pieces of
about :attr:`AlignSettings.piece` seconds, force-aligned two at a time, one
per core.  A forced pass keeps every state of its words alive at every
frame, so its cost grows faster than its length: four 6.5 s pieces cost
less than two 13 s halves, and the pieces keep both cores evenly busy."""

from __future__ import annotations

from ..audio import Audio
from .decoding import _decoder, _whole, _word_pass
from .model import FRAME, AlignSettings


def piece_count(duration: float, settings: AlignSettings) -> int:
    """An even number of pieces (at least two) of about ``settings.piece`` s."""
    return 2 * max(1, round(duration / (2 * settings.piece)))


def _segments(audio: Audio, prons: list[list[str]], settings: AlignSettings) -> list[tuple[int, int]] | None:
    """(start, end) frame of every word from a quick forced word pass over
    the whole clip, or None if it fails.  The pass scores every third frame
    only (a cut needs the pauses, not exact boundaries); very fast speech
    can leave it without a path, and every second frame is tried then."""
    pcm = audio.pcm16()
    tokens = [f"w{i}" for i in range(len(prons))]
    for ds in (3, 2):
        first = _word_pass(_decoder(prons, 0, settings, ds=ds), pcm, "all", tokens, "all")
        if first[0] != "failed":
            return first[2]
    return None


# A cut goes in the middle of a pause between two words.  Pauses of at least
# CUT_PAUSE frames are preferred (each piece then starts and ends in
# silence); a wider one, counted up to WIDE_PAUSE frames, may lie up to
# PAUSE_WORTH frames further from the cut's even share of the clip per frame
# of extra width.
CUT_PAUSE = 10
WIDE_PAUSE = 30
PAUSE_WORTH = 2


def _choose_cuts(segs: list[tuple[int, int]], parts: int, frames: int) -> list[tuple[int, float]] | None:
    """Where to cut words with frames ``segs``, in a clip of ``frames``
    frames, into ``parts`` pieces (at most one per two words).  A piece's
    passes cost about its length times its words, silence included, so each
    cut aims at its even share of the whole clip and the pieces keep both
    cores equally busy; it goes in the pause that scores best by
    :data:`CUT_PAUSE`, :data:`WIDE_PAUSE` and :data:`PAUSE_WORTH` within
    half a piece of that share.  (words before the cut, cut time) per cut,
    in order, possibly fewer than ``parts - 1``; None if no cut is made."""
    parts = min(parts, len(segs) // 2)
    if parts < 2:
        return None
    reach = frames / parts / 2
    cuts: list[tuple[int, float]] = []
    for j in range(1, parts):
        target = frames * j / parts
        best = None
        for i in range(1, len(segs)):
            gap = segs[i][0] - segs[i - 1][1]
            centre = (segs[i][0] + segs[i - 1][1]) / 2
            if abs(centre - target) > reach or (cuts and i <= cuts[-1][0]):
                continue
            score = (gap >= CUT_PAUSE, PAUSE_WORTH * min(gap, WIDE_PAUSE) - abs(centre - target))
            if best is None or score > best[0]:
                best = (score, i, centre)
        if best is not None:
            cuts.append((best[1], best[2] * FRAME))
    return cuts or None


def _align_pieces(audio: Audio, prons: list[list[str]], settings: AlignSettings, pool, place) -> bool:
    """Cut the clip where :func:`_choose_cuts` says on the words of
    :func:`_segments`, then force-align every piece with its own words, two
    at a time, the longest first.  Returns False, having placed nothing, if
    any pass fails."""
    segs = _segments(audio, prons, settings)
    frames = int(round(audio.duration / FRAME))
    cuts = _choose_cuts(segs, piece_count(audio.duration, settings), frames) if segs else None
    if cuts is None:
        pool.shutdown()
        return False
    bounds = [(0, 0.0)] + cuts + [(len(prons), audio.duration)]
    pieces = [(k0, k1, t0, t1) for (k0, t0), (k1, t1) in zip(bounds[:-1], bounds[1:])]
    try:
        # No speech mask, so no filler pass: a piece is short and cut at
        # pauses, so a hesitation cannot wander far from its place
        # (bench/timing.py: the same phone starts with the filler pass;
        # cold_corpus 1.39 s without it, 1.60 s with it).
        futures = {p: pool.submit(_whole, audio, prons[p[0]:p[1]], p[0], p[2], p[3], settings)
                   for p in sorted(pieces, key=lambda p: p[2] - p[3])}
        results = [(p, futures[p].result()) for p in pieces]
    finally:
        pool.shutdown()
    if any(r[0] == "failed" for _, r in results):
        return False
    for (k0, k1, t0, t1), (kind, _, payload) in results:
        place(kind, payload, k0, k1, t0, t1)
    return True
