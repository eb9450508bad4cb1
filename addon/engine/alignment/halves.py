"""Clips of 10 to 90 s: cut in two at the pause nearest the middle and both
halves force-aligned at once, one per core."""

from __future__ import annotations

from ..audio import Audio
from .decoding import _decoder, _whole
from .model import FRAME, AlignSettings


def _split_words(audio: Audio, prons: list[list[str]], settings: AlignSettings) -> tuple[int, float] | None:
    """Where to cut a long clip in two, and how many words go before the cut.

    A quick forced word pass over the whole clip (scoring every third frame
    only: the cut needs the pauses, not exact boundaries) finds the words; the cut goes in the middle of the pause between
    two words nearest the middle of the speech.  Returns (words before the
    cut, cut time) or None if the pass fails."""
    decoder = _decoder(prons, 0, settings, ds=3)
    tokens = [f"w{i}" for i in range(len(prons))]
    try:
        decoder.set_align_text(" ".join(tokens))
        decoder.start_utt()
        decoder.process_raw(audio.pcm16(), full_utt=True)
        decoder.end_utt()
        segs = [(sg.start_frame, sg.end_frame + 1) for sg in (decoder.seg() or []) if sg.word.startswith("w")]
    except RuntimeError:
        return None
    if len(segs) != len(prons) or len(segs) < 4:
        return None
    lo, hi = segs[0][0], segs[-1][1]
    mid = (lo + hi) / 2
    quarter = (hi - lo) / 4
    best = None
    for i in range(1, len(segs)):
        gap = segs[i][0] - segs[i - 1][1]
        centre = (segs[i][0] + segs[i - 1][1]) / 2
        if abs(centre - mid) > quarter:
            continue
        # The widest pause near the middle; ties go to the one nearer it.
        score = (min(gap, 30), -abs(centre - mid))
        if best is None or score > best[0]:
            best = (score, i, centre)
    if best is None:
        return None
    return best[1], best[2] * FRAME


def _align_halves(audio: Audio, prons: list[list[str]], settings: AlignSettings, pool, place) -> bool:
    """A long clip: find where to cut it in two (see :func:`_split_words`),
    then force-align both halves with their own words at once.  Returns
    False, having placed nothing, if any pass fails."""
    n = len(prons)
    split = _split_words(audio, prons, settings)
    if split is None:
        pool.shutdown()
        return False
    k, cut = split
    try:
        futs = [pool.submit(_whole, audio, prons[:k], 0, 0.0, cut, settings),
                pool.submit(_whole, audio, prons[k:], k, cut, audio.duration, settings)]
        head, tail = futs[0].result(), futs[1].result()
    finally:
        pool.shutdown()
    if head[0] == "failed" or tail[0] == "failed":
        return False
    place(head[0], head[2], 0, k, 0.0, cut)
    place(tail[0], tail[2], k, n, cut, audio.duration)
    return True
