"""Long recordings, window by window, in bounded memory.

A forced pass over a whole clip keeps, with the wide beams this aligner
needs, every state of the transcript's grammar alive at every frame: its
memory and time grow with the square of the clip's length (a ten-minute
recording took 2 GB).  A long clip is therefore aligned in windows of at
most :attr:`AlignSettings.window` seconds, walked from both ends at once
(two processes):

* the head side decodes its window with a grammar that lets the acoustic
  model take a prefix of the words not yet placed (as many as the
  transcript's speaking rate says the window can hold, with room to spare),
  keeps the words before the widest silence between two words in the back
  half of the window, and moves on from that silence with the next word.
  The words near the window's end, where the audio is cut in mid-speech,
  are decoded again by the next window;
* the tail side does the same backwards from the last word, with suffix
  grammars;
* the words left between the two sides (at most about two windows of
  speech, and the long silence they meet in, if there is one near the
  middle) are force-aligned as a stretch whose words are known exactly
  (:func:`.chunks._run_middle`, which falls back on grammars and estimates).

Windows begin where speech does, and one whose speech stops at a long
silence ends in it.  A window that cannot be decoded, or that offers no gap
between words to cut at, is tried once more with twice the candidates; if
that fails too, the words its speech holds at the transcript's speaking
rate are placed by estimate (marked, with a note) and the walk goes on.
Each decode holds at most one window of audio and its candidate words, so
the aligner's memory stays bounded whatever the length, and its time grows
in proportion to the length.
"""

from __future__ import annotations

import concurrent.futures
import itertools
import multiprocessing

import numpy as np

from ..audio import Audio
from .chunks import _cover_speech, _run_middle
from .decoding import _decode, _decoder
from .model import FRAME, AlignSettings, word_frames
from .parallel import _Inline, _pool
from .speech import runs

#: A window is decoded at most this many times (twice the candidates each time).
_TRIES = 2
#: The words decoded in the last seconds of a window (this long, or 15% of
#: the window if less), where the audio is cut in mid-speech, are not
#: trusted: the cut is looked for before them.
_END_GUARD = 2.0
#: A silence this long (s) near the middle of a clip is where the two sides meet.
_LONG_SILENCE = 2.0
#: Speech (s) after a window's last word that still lets it be its last.
_TRAILING = 0.35
#: The cut between the words kept and those decoded again lies this far
#: into the window or further.
_FAR = 0.5


def _cut(frames: list[tuple[int, int]], side: str, wmask: np.ndarray, guard: int) -> tuple[int, int] | None:
    """Where to cut a decoded window: (how many words to keep, counted from
    the side's own end; the frame the walk goes on from).

    The cut goes after the word before the longest silence (by the speech
    mask, up to 0.3 s; then the furthest from the side's start) between two
    decoded words in the far part of the window: past :data:`_FAR` of it
    from the side's start (or failing that past a quarter of it), and not
    within ``guard`` frames of its far end.  The walk goes on from the middle
    of the silence that follows the last word kept (from the word's edge
    when speech follows it at once: the decoder may have stretched the gap
    over words it had no candidates left for).  None if there is no gap."""
    n, size = len(frames), len(wmask)
    # Silence at the window's far end and less than :data:`_TRAILING` of
    # speech (by the generous mask) after the words found: they are all the
    # window holds, and the cut goes in that silence.
    if side == "head" and float(wmask[frames[-1][1]:].sum()) * FRAME < _TRAILING and not wmask[-guard:].any():
        return n, size - guard // 2
    if side == "tail" and float(wmask[:frames[0][0]].sum()) * FRAME < _TRAILING and not wmask[:guard].any():
        return n, guard // 2
    for far in (_FAR, 0.25):
        best = None
        for i in range(n - 1):
            gap_a, gap_b = frames[i][1], frames[i + 1][0]
            centre = (gap_a + gap_b) / 2
            if side == "head":
                ok = far * size <= centre <= size - guard
                keep = i + 1
            else:
                ok = guard <= centre <= (1 - far) * size
                keep = n - 1 - i
            if not ok:
                continue
            silent = int((~wmask[gap_a:gap_b]).sum()) if gap_b > gap_a else 0
            score = (min(silent, 30), keep)
            if best is None or score > best[0]:
                best = (score, keep, i)
        if best is not None:
            _, keep, i = best
            if side == "head":
                edge, limit = frames[i][1], frames[i + 1][0]
                run = _silent_run(wmask[edge:limit])
                return keep, edge + run // 2
            edge, limit = frames[i + 1][0], frames[i][1]
            run = _silent_run(wmask[limit:edge][::-1])
            return keep, edge - run // 2
    return None


def _silent_run(mask: np.ndarray) -> int:
    """Frames of silence at the start of ``mask``."""
    speech = np.flatnonzero(mask)
    return int(speech[0]) if len(speech) else len(mask)


#: Share of the alignment's progress reached when both walks are done.
_WALKS_SHARE = 0.6


class _Reach:
    """How far each side's walk has got (0 to 1): in memory shared with the
    forked workers (read by polling), or reported at once when the walks run
    in this process."""

    def __init__(self, forked: bool, progress):
        self.values = multiprocessing.get_context("fork").Array("d", 2, lock=False) if forked else [0.0, 0.0]
        self.progress = None if forked else progress

    def set(self, side: str, fraction: float) -> None:
        self.values[0 if side == "head" else 1] = min(1.0, max(0.0, fraction))
        if self.progress:
            self.progress(self.share())

    def share(self) -> float:
        return _WALKS_SHARE * (self.values[0] + self.values[1]) / 2


def _walk(side: str, audio: Audio, prons: list[list[str]], mask: np.ndarray, start: float, stop: float,
          rate: float, settings: AlignSettings, reach: _Reach | None = None):
    """One side's walk.  The head walks forward from word 0 and time
    ``start`` while more than a window of audio is left before ``stop``; the
    tail walks backward from the last word and time ``stop`` while more than
    a window is left after ``start``.

    Returns (placed, word): ``placed`` a list of (word start, word end, t0,
    t1, kind, payload, cut) in the order walked (``cut``: where the walk went
    on from), and the first word left (head: the next unplaced; tail: one
    past the last unplaced)."""
    n = len(prons)
    lo, hi = 0, n
    placed = []
    t = start if side == "head" else stop
    W = settings.window
    guard = int(round(min(_END_GUARD, 0.15 * W) / FRAME))
    while hi - lo > 1:
        if reach is not None:
            reach.set(side, (t - start if side == "head" else stop - t) / max(stop - start, FRAME))
        # A window begins (head) or ends (tail) where the speech does: a
        # long silence is stepped over, not offered words it cannot hold.
        if side == "head":
            k0, k1 = int(t / FRAME), int(stop / FRAME)
            voiced = np.flatnonzero(mask[k0:k1])
            if len(voiced) == 0:
                break
            t = max(t, (k0 + voiced[0]) * FRAME - settings.margin)
        else:
            k0, k1 = int(start / FRAME), int(np.ceil(t / FRAME))
            voiced = np.flatnonzero(mask[k0:k1])
            if len(voiced) == 0:
                break
            t = min(t, (k0 + voiced[-1] + 1) * FRAME + settings.margin)
        if (stop - t if side == "head" else t - start) <= W:
            break
        a, b = (t, t + W) if side == "head" else (t - W, t)
        # A window whose speech stops (starts, for the tail) at a long
        # silence ends in that silence: its words are then all it holds.
        fa, fb = int(round(a / FRAME)), int(round(b / FRAME))
        run = _silent_run(mask[fa:fb][::-1] if side == "head" else mask[fa:fb])
        if run * FRAME >= _LONG_SILENCE and run < fb - fa:
            if side == "head":
                b -= (run * FRAME - 0.5 * _LONG_SILENCE)
            else:
                a += (run * FRAME - 0.5 * _LONG_SILENCE)
            fa, fb = int(round(a / FRAME)), int(round(b / FRAME))
        wmask = mask[fa:fb]
        speech = float(wmask.sum()) * FRAME
        size = int(speech * rate * 1.3) + 8
        pcm = audio.pcm16(a, b)
        if not pcm:
            break
        got = None
        for _ in range(_TRIES):
            size = min(size, hi - lo - 1)  # at least one word is left for the middle
            if size < 1:
                break
            window = range(lo, lo + size) if side == "head" else range(hi - size, hi)
            decoder = _decoder([prons[i] for i in window], window[0], settings)
            kind, used, payload = _decode(decoder, pcm, side, [f"w{i}" for i in window], side)
            if kind != "failed":
                cut = _cut(word_frames(kind, payload), side, wmask, guard)
                if cut is None:
                    # The grammar search may stop early and call the speech
                    # after its last word silence: force more words.
                    kind, used, payload = _cover_speech(decoder, pcm, wmask, side, kind, used, payload,
                                                        0, size, window[0])
                    cut = _cut(word_frames(kind, payload), side, wmask, guard)
                if cut is not None:
                    got = (kind, used, payload, cut)
                    del decoder
                    break
            del decoder
            size *= 2
        if got is None:
            # Placed by estimate: the words the window's speech holds at the
            # transcript's speaking rate, cut at the widest pause of its far half.
            cut = _estimate_cut(wmask, side)
            part = wmask[:cut] if side == "head" else wmask[cut:]
            count = min(hi - lo - 1, max(1, int(round(float(part.sum()) * FRAME * rate))))
            if count < 1:
                break
            if side == "head":
                placed.append((lo, lo + count, a, a + cut * FRAME, "failed",
                               "the window's words could not be aligned", a + cut * FRAME))
                lo, t = lo + count, a + cut * FRAME
            else:
                placed.append((hi - count, hi, a + cut * FRAME, b, "failed",
                               "the window's words could not be aligned", a + cut * FRAME))
                hi, t = hi - count, a + cut * FRAME
            continue
        kind, used, payload, (keep, cut) = got
        if side == "head":
            placed.append((lo, lo + keep, a, b, kind, payload[:keep], a + cut * FRAME))
            lo, t = lo + keep, a + cut * FRAME
        else:
            placed.append((hi - keep, hi, a, b, kind, payload[used - keep:], a + cut * FRAME))
            hi, t = hi - keep, a + cut * FRAME
    return placed, (lo if side == "head" else hi)


#: The clips being aligned, for the forked workers, by a key of their own.
_SHARED: dict = {}
_KEYS = itertools.count()


def _walk_shared(key: int, side: str, start: float, stop: float, rate: float, settings: AlignSettings):
    audio, prons, mask, reach = _SHARED[key]
    return _walk(side, audio, prons, mask, start, stop, rate, settings, reach)


def _estimate_cut(wmask: np.ndarray, side: str) -> int:
    """Frame of the middle of the longest silence in the window's far half
    (the half away from the side's start), or the window's far end."""
    n = len(wmask)
    lo, hi = (n // 2, n) if side == "head" else (0, n - n // 2)
    silent = runs(wmask[lo:hi], False)
    if not len(silent):
        return n if side == "head" else 0
    i, j = silent[int(np.argmax(silent[:, 1] - silent[:, 0]))] + lo
    return int((i + j) // 2)


def _meeting(mask: np.ndarray, start: float, stop: float) -> tuple[float, float]:
    """Where the head's walk stops and the tail's begins: the middle of the
    clip, or, when a silence of :data:`_LONG_SILENCE` or more begins in its
    middle third, that silence's edges (the two sides then meet in it and
    each walk ends on complete speech)."""
    middle = (start + stop) / 2
    a, b = int((start + (stop - start) / 3) / FRAME), int((stop - (stop - start) / 3) / FRAME)
    silent = runs(mask[a:], False)
    silent = silent[(silent[:, 0] < b - a) & ((silent[:, 1] - silent[:, 0]) * FRAME >= _LONG_SILENCE)]
    if not len(silent):
        return middle, middle
    i, j = silent[int(np.argmax(silent[:, 1] - silent[:, 0]))] + a
    return int(i) * FRAME, int(j) * FRAME


def align_stream(audio: Audio, prons: list[list[str]], mask: np.ndarray, settings: AlignSettings,
                 place, progress) -> None:
    """Align a long clip window by window (see the module's docstring),
    calling ``place(kind, payload, word start, word end, t0, t1)`` for every
    stretch, in any order."""
    n = len(prons)
    idx = np.flatnonzero(mask)
    start = max(0.0, idx[0] * FRAME - settings.margin)
    stop = min(audio.duration, (idx[-1] + 1) * FRAME + settings.margin)
    # Words per second of speech, over the whole clip.
    rate = n / max(FRAME, float(mask.sum()) * FRAME)
    head_stop, tail_start = _meeting(mask, start, stop)
    # The worker processes are forked with the clip in memory: they read it
    # from there (shared with this process) rather than receive a copy.
    key = next(_KEYS)
    pool = _pool(settings)
    reach = _Reach(pool is not None, progress) if progress else None
    _SHARED[key] = (audio, prons, mask, reach)
    runner = pool or _Inline()
    try:
        fut_h = runner.submit(_walk_shared, key, "head", start, head_stop, rate, settings)
        fut_t = runner.submit(_walk_shared, key, "tail", tail_start, stop, rate, settings)
        if pool is not None and reach is not None:
            pending = {fut_h, fut_t}
            while pending:
                _done, pending = concurrent.futures.wait(pending, timeout=0.5)
                progress(reach.share())
        heads, lo = fut_h.result()
        tails, hi = fut_t.result()
    finally:
        runner.shutdown()
        del _SHARED[key]
    if progress:
        progress(_WALKS_SHARE)
    # The two sides walked apart, each on its own count of words: should
    # their words meet or cross, the innermost windows give way.
    while (tails or heads) and lo >= hi:
        if tails:
            tails.pop()
        else:
            heads.pop()
        hi = tails[-1][0] if tails else n
        lo = heads[-1][1] if heads else 0
    ta = heads[-1][6] if heads else start
    tb = tails[-1][6] if tails else stop
    for wa, wb, a, b, kind, payload, _ in heads + tails:
        place(kind, payload, wa, wb, a, b)
    if lo < hi:
        for wa, wb, a, b, kind, payload in _run_middle(audio, ta, tb, prons[lo:hi], lo, settings, mask):
            place(kind, payload, wa, wb, a, b)
