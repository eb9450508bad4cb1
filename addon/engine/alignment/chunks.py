"""The fallback when forced alignment of a stretch fails: the audio is cut
at its pauses into chunks, words are assigned to chunks from both ends by
grammars that let the acoustic model take a prefix (or a suffix) of the
words, and what is left between is force-aligned or estimated."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..audio import Audio
from .decoding import _decode, _decoder
from .model import FRAME, AlignSettings, word_frames
from .parallel import _Inline, _pool
from .speech import _longest_run, pauses


@dataclass
class _Chunk:
    start: float
    end: float
    speech: float    # seconds of speech inside


def plan_chunks(mask: np.ndarray, settings: AlignSettings, duration: float) -> list[_Chunk]:
    """Cut the audio at its pauses into chunks no longer than ``max_chunk``
    (a stretch without a pause may be longer)."""
    idx = np.flatnonzero(mask)
    speech_start = max(0.0, idx[0] * FRAME - settings.margin)
    speech_end = min(duration, (idx[-1] + 1) * FRAME + settings.margin)
    gaps = pauses(mask, settings.min_pause)
    bounds = [speech_start] + [(a + b) / 2 for a, b in gaps] + [speech_end]
    chunks: list[_Chunk] = []
    for a, b in zip(bounds[:-1], bounds[1:]):
        speech = float(mask[int(a / FRAME): int(b / FRAME)].sum()) * FRAME
        if chunks and chunks[-1].end - chunks[-1].start + (b - a) <= settings.max_chunk:
            chunks[-1] = _Chunk(chunks[-1].start, b, chunks[-1].speech + speech)
        else:
            chunks.append(_Chunk(a, b, speech))
    return chunks


def _cover_speech(decoder, pcm, mask, side, kind, used, payload, lo, hi, first):
    """The grammar search may stop early, letting "silence" swallow speech it
    fits poorly.  If much of the chunk's speech lies outside the words found,
    force more words (as many as fit at the speaking rate measured on the
    words found) and keep the first count that aligns."""
    frames = word_frames(kind, payload)
    if side == "head":
        uncovered = float(mask[frames[-1][1]:].sum()) * FRAME
    else:
        uncovered = float(mask[:frames[0][0]].sum()) * FRAME
    if uncovered < 0.35:
        return kind, used, payload
    per_word = max(0.08, sum(b - a for a, b in frames) * FRAME / used)
    extra = max(1, int(round(uncovered / per_word)))
    for n in sorted({used + extra + d for d in (0, -1, 1, -2, 2) if used < used + extra + d < hi - lo},
                    key=lambda n: abs(n - used - extra)):
        window = range(lo, lo + n) if side == "head" else range(hi - n, hi)
        res = _decode(decoder, pcm, "all", [f"w{first + i}" for i in window], "all")
        if res[0] != "failed":
            return res
    return kind, used, payload


def _run_side(side: str, pcms: list[bytes], speech: list[float], prons: list[list[str]],
              first: int, settings: AlignSettings, masks: list[np.ndarray]):
    """Align chunks one after another from one end of the transcript.

    "head" walks forward from word ``first``; "tail" walks backward from the
    last word.  Each chunk is offered a window of candidate words sized from
    its speech time and the acoustic model picks how many it holds.  Stops at
    the first chunk it cannot align; the rest is left to the middle.
    Returns a list of (chunk position, word start, word end, kind, payload).
    """
    decoder = _decoder(prons, first, settings)
    out = []
    lo, hi = 0, len(prons)  # words still unplaced, relative to ``first``
    order = range(len(pcms)) if side == "head" else range(len(pcms) - 1, -1, -1)
    for n, k in enumerate(order):
        if hi - lo < 2:
            break
        guess = int(speech[k] / 0.16) + 6
        while True:
            size = min(hi - lo - 1, guess)  # leave at least one word for the middle
            if size < 1:
                return out
            window = range(lo, lo + size) if side == "head" else range(hi - size, hi)
            tokens = [f"w{first + i}" for i in window]
            kind, used, payload = _decode(decoder, pcms[k], f"{side}{n}_{size}", tokens, side)
            if kind == "failed":
                return out
            if used < size or size == hi - lo - 1:
                break
            guess *= 2  # every candidate was used: the window was too small
        keep = _trusted(kind, payload, masks[k], side)
        if keep < used:
            # Speech swallowed between two words: the words beyond it are
            # misplaced.  Keep the ones before it and leave the rest (and the
            # audio after them) to the middle.
            if keep:
                payload = payload[:keep] if side == "head" else payload[used - keep:]
                a, b = (lo, lo + keep) if side == "head" else (hi - keep, hi)
                out.append((k, first + a, first + b, kind, payload))
            return out
        if used < hi - lo - 1:
            kind, used, payload = _cover_speech(decoder, pcms[k], masks[k], side, kind, used, payload,
                                                lo, hi, first)
        a, b = (lo, lo + used) if side == "head" else (hi - used, hi)
        out.append((k, first + a, first + b, kind, payload))
        lo, hi = (b, hi) if side == "head" else (lo, a)
    return out


def _trusted(kind, payload, mask: np.ndarray, side: str, swallowed: float = 1.0, lead: bool = False) -> int:
    """How many words, counted from the side's own end, come before the first
    gap between words that holds ``swallowed`` s or more of continuous speech.
    A pause, even a long one at the end of a verse line, is not a second of
    unbroken speech; a word pass that calls such a stretch silence has
    skipped words there, and the words after it are misplaced.

    With ``lead``, the stretch between the side's own end of the audio and
    its first word is checked too (used in the middle, whose ends are the
    edges of words already placed; at the clip's ends breath and noise pass
    for speech too often)."""
    frames = word_frames(kind, payload)
    n = len(frames)
    limit = int(round(swallowed / FRAME))
    before = mask[:frames[0][0]] if side == "head" else mask[frames[-1][1]:]
    if lead and _longest_run(before) >= limit:
        return 0
    order = range(n - 1) if side == "head" else range(n - 2, -1, -1)
    for count, i in enumerate(order, start=1):
        if _longest_run(mask[frames[i][1]:frames[i + 1][0]]) >= limit:
            return count
    return n


def _run_middle(audio: Audio, t0: float, t1: float, prons: list[list[str]], first: int,
                settings: AlignSettings, mask: np.ndarray | None = None):
    """Align the words ``first .. first+len(prons)`` to the audio t0..t1.

    Forced alignment first.  If it fails, the grammar search takes as many
    words as it can from the front, then from the back of what remains; the
    words still left between are returned unplaced (for the estimate).
    Returns a list of (word start, word end, t0, t1, kind, payload).
    """
    decoder = _decoder(prons, first, settings)
    n = len(prons)
    tokens = [f"w{first + i}" for i in range(n)]
    kind, used, payload = _decode(decoder, audio.pcm16(t0, t1), "all", tokens, "all")
    if kind != "failed":
        return [(first, first + n, t0, t1, kind, payload)]
    out = []
    lo, hi, a, b = 0, n, t0, t1
    for mode in ("head", "tail"):
        if hi - lo < 1 or b - a < 0.05:
            break
        window = tokens[lo:hi]
        kind, used, payload = _decode(decoder, audio.pcm16(a, b), f"mid_{mode}", window, mode)
        if kind == "failed" or used == 0:
            continue
        if mask is not None:
            keep = _trusted(kind, payload, mask[int(round(a / FRAME)):int(round(b / FRAME))], mode,
                            lead=mode == "head")
            if keep == 0:
                continue
            payload = payload[:keep] if mode == "head" else payload[used - keep:]
            used = keep
        frames = word_frames(kind, payload)
        if mode == "head":
            out.append((first + lo, first + lo + used, a, b, kind, payload))
            a, lo = a + frames[-1][1] * FRAME, lo + used
        else:
            out.append((first + hi - used, first + hi, a, b, kind, payload))
            b, hi = a + frames[0][0] * FRAME, hi - used
    if lo < hi:
        out.append((first + lo, first + hi, a, b, "failed", "forced alignment failed"))
    return out


def _align_chunked(audio, prons, mask, settings, place, result, progress) -> None:
    """The fallback when forced alignment of the whole clip fails: chunks cut
    at pauses, walked from both ends with prefix and suffix grammars, the
    middle force-aligned or estimated."""
    n = len(prons)
    chunks = plan_chunks(mask, settings, audio.duration)
    pcms = [audio.pcm16(c.start, c.end) for c in chunks]
    speech = [c.speech for c in chunks]
    masks = [mask[int(round(c.start / FRAME)): int(round(c.end / FRAME))] for c in chunks]
    # Chunks before the middle one are walked forward from the first word,
    # chunks after it backward from the last, in two processes at once; the
    # middle chunk takes the words left between them.
    K = len(chunks)
    head_n = (K - 1) // 2
    tail_n = K - 1 - head_n
    pool = _pool(settings) if head_n and tail_n else None
    runner = pool or _Inline()
    try:
        fut_h = runner.submit(_run_side, "head", pcms[:head_n], speech[:head_n], prons, 0, settings,
                              masks[:head_n]) if head_n else None
        fut_t = runner.submit(_run_side, "tail", pcms[K - tail_n:], speech[K - tail_n:], prons, 0, settings,
                              masks[K - tail_n:]) if tail_n else None
        heads = fut_h.result() if fut_h else []
        tails = fut_t.result() if fut_t else []
    finally:
        runner.shutdown()
    if progress:
        progress(0.6)
    lo, c_lo = 0, 0
    for k, wa, wb, kind, payload in heads:
        place(kind, payload, wa, wb, chunks[k].start, chunks[k].end)
        lo, c_lo = wb, k + 1
    hi, c_hi = n, K
    for k, wa, wb, kind, payload in tails:
        kk = K - tail_n + k
        place(kind, payload, wa, wb, chunks[kk].start, chunks[kk].end)
        hi, c_hi = wa, kk
    if c_hi - c_lo > 1 and hi - lo > 1:
        # A side stopped early: walk forward over what is left, but the last chunk.
        rest = range(c_lo, c_hi - 1)
        walked = 0
        for k, wa, wb, kind, payload in _run_side("head", [pcms[k] for k in rest], [speech[k] for k in rest],
                                                  prons[lo:hi], lo, settings, [masks[k] for k in rest]):
            place(kind, payload, wa, wb, chunks[c_lo + k].start, chunks[c_lo + k].end)
            lo, walked = wb, k + 1
        c_lo += walked
    if lo < hi:
        # The middle takes the words left between the two sides and the audio
        # left between them: a side may have stopped short of its chunk's end
        # (the grammar search ended early and forcing more words failed), and
        # the speech it left belongs to the next unplaced words.
        t0, t1 = chunks[c_lo].start, chunks[c_hi - 1].end
        if lo > 0 and result[lo - 1]:
            t0 = min(t0, result[lo - 1][-1][2])
        if hi < n and result[hi]:
            t1 = max(t1, result[hi][0][1])
        for wa, wb, a, b, kind, payload in _run_middle(audio, t0, t1, prons[lo:hi], lo, settings, mask):
            place(kind, payload, wa, wb, a, b)
