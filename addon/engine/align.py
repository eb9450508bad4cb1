"""Forced alignment of a transcript to speech with pocketsphinx, offline.

pocketsphinx aligns in two passes (words, then phones).  With its default
beams it fails on real recordings in three known ways: the last word can be
dropped, long clips end with "Final result does not match the grammar", and
the phone pass gives up with "Failed to set up sub-word alignment" on clips
with long pauses or quiet, fast speech.  All three come from pruning: the
right path through the grammar is cut off where the acoustic model fits the
speech poorly.  This module therefore:

1. searches with beams far wider than the defaults (1e-200: almost no
   pruning).  A forced alignment holds only the transcript's own words, so
   the search stays small, and it then succeeds on whole clips of a minute;
2. aligns a clip in one forced pass.  A clip longer than
   :attr:`AlignSettings.split_above` is cut in two and both halves are
   aligned at once, in two processes: a quick forced word pass over the
   whole clip, scoring every second frame only, finds the pause between two
   words nearest the middle, and the cut goes there;
3. checks every pass word by word against the transcript (each word is a
   unique token in a dictionary holding only the clip's words);
4. where forced alignment still fails (audio that does not hold the
   transcript, say), falls back to smaller pieces: the audio is cut at its
   pauses into chunks, words are assigned to chunks by grammars that let the
   acoustic model take a prefix (or a suffix) of the words, and a stretch that still cannot be aligned has its
   phonemes placed by estimate: the words are spread over the stretch's
   speech (pauses skipped) in proportion to their expected length, each
   phone taking a share of its word by its typical duration.  Such words and
   phonemes carry ``estimated = True``.  When only the phone pass fails, the
   word times of the first pass are kept and only the phones inside each
   word are estimated.
"""

from __future__ import annotations

import math
import os
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from .audio import Audio
from .errors import AlignmentError, AudioError, TranscriptError
from .phonemes import VOWELS

FRAME = 0.01  # pocketsphinx's frame period (100 frames per second)

#: Typical duration of a phone, seconds, for estimates and for splitting.
TYPICAL_DURATION = {"vowel": 0.10, "diphthong": 0.14, "consonant": 0.07}


def typical_duration(phone: str) -> float:
    if phone in {"AW", "AY", "EY", "OW", "OY"}:
        return TYPICAL_DURATION["diphthong"]
    return TYPICAL_DURATION["vowel" if phone in VOWELS else "consonant"]


@dataclass
class AlignSettings:
    """Knobs of the aligner.  The defaults were measured on real speech."""

    split_above: float = 30.0    # clips longer than this are aligned as two halves at once, s
    max_chunk: float = 12.0      # longest chunk of the fallback, s
    min_pause: float = 0.30      # shortest silence the audio may be cut at, s
    margin: float = 0.12         # silence kept around each chunk's speech, s
    beam: float = 1e-200
    pbeam: float = 1e-200
    wbeam: float = 1e-200
    # Chance of a pause between two words.  pocketsphinx's default (0.005)
    # suits dictation decoded with a language model; in dialogue, pauses,
    # breaths and hesitations between words are common.
    silprob: float = 0.1
    workers: int = 0             # processes; 0 = one per core


@dataclass
class AlignedWord:
    text: str
    start: float
    end: float
    phones: list[str]
    source: str = ""             # where the pronunciation came from
    estimated: bool = False


@dataclass
class AlignedPhone:
    phone: str
    start: float
    end: float
    word_index: int
    estimated: bool = False


@dataclass
class Alignment:
    words: list[AlignedWord]
    phones: list[AlignedPhone]
    duration: float
    notes: list[str] = field(default_factory=list)
    #: Notes the user must see (words of the transcript left out, ...): also in ``notes``.
    warnings: list[str] = field(default_factory=list)

    @property
    def n_estimated(self) -> int:
        return sum(p.estimated for p in self.phones)


# ---------------------------------------------------------------------------
# Voice activity from short-time energy

def frame_levels(audio: Audio, hop: float = FRAME) -> np.ndarray:
    """RMS level in dBFS of consecutive 25 ms windows every ``hop`` seconds."""
    step = int(round(hop * audio.rate))
    win = int(round(0.025 * audio.rate))
    x = audio.samples.astype(np.float64)
    n = max(1, (len(x) - win) // step + 1) if len(x) >= win else 1
    power = np.convolve(x * x, np.ones(win) / win, mode="full")[win - 1 :: step][:n] if len(x) >= win \
        else np.array([np.mean(x * x) if len(x) else 0.0])
    return 10.0 * np.log10(power + 1e-12)


def speech_mask(levels: np.ndarray, audio: Audio | None = None) -> tuple[np.ndarray, float]:
    """Which 10 ms frames may hold speech.  Returns (mask, threshold dB).

    The mask is built to be safe to cut at, not to be tight: a frame counts
    as speech if pocketsphinx's voice-activity detector (its loosest mode)
    hears a voice there, or if it is 10 dB above the noise floor.  Quiet,
    breathy or noisy speech (a speaker with a cold) defeats either test alone.
    """
    floor = float(np.percentile(levels, 10))
    peak = float(np.percentile(levels, 99))
    if peak < -70.0 or peak - floor < 6.0:
        return np.zeros(len(levels), bool), peak
    threshold = floor + 10.0
    mask = levels > threshold
    if audio is not None:
        import pocketsphinx

        vad = pocketsphinx.Vad(pocketsphinx.Vad.LOOSE, audio.rate, FRAME)
        pcm = audio.pcm16()
        fb = vad.frame_bytes
        voiced = np.fromiter((vad.is_speech(pcm[k:k + fb]) for k in range(0, len(pcm) - fb + 1, fb)),
                             bool)
        n = min(len(voiced), len(mask))
        mask[:n] |= voiced[:n]
    # Close gaps shorter than 80 ms (stop closures).  Short blips are kept:
    # dropping them would put cuts inside quiet speech.
    return _close_runs(mask, False, 8), threshold


def _close_runs(mask: np.ndarray, value: bool, shorter_than: int) -> np.ndarray:
    out = mask.copy()
    n = len(mask)
    i = 0
    while i < n:
        if mask[i] == value:
            j = i
            while j < n and mask[j] == value:
                j += 1
            if 0 < i and j < n and j - i < shorter_than:
                out[i:j] = not value
            i = j
        else:
            i += 1
    return out


def pauses(mask: np.ndarray, min_pause: float) -> list[tuple[float, float]]:
    """Silent stretches inside the speech (not before or after it), in seconds."""
    idx = np.flatnonzero(mask)
    if len(idx) == 0:
        return []
    found = []
    first, last = idx[0], idx[-1]
    i = first
    while i <= last:
        if not mask[i]:
            j = i
            while j <= last and not mask[j]:
                j += 1
            if (j - i) * FRAME >= min_pause:
                found.append((i * FRAME, j * FRAME))
            i = j
        else:
            i += 1
    return found


# ---------------------------------------------------------------------------
# Chunks

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


# ---------------------------------------------------------------------------
# pocketsphinx

def _decoder(prons: Sequence[Sequence[str]], first: int, settings: AlignSettings, **extra):
    """A decoder whose dictionary holds only the given words, as tokens w<i>."""
    import pocketsphinx

    with tempfile.NamedTemporaryFile("w", suffix=".dict", delete=False) as fh:
        for k, ph in enumerate(prons):
            fh.write(f"w{first + k} {' '.join(ph)}\n")
        path = fh.name
    try:
        return pocketsphinx.Decoder(
            lm=None, dict=path, bestpath=False, samprate=16000, loglevel="FATAL",
            beam=settings.beam, pbeam=settings.pbeam, wbeam=settings.wbeam, silprob=settings.silprob, **extra)
    finally:
        os.unlink(path)


def _grammar(tokens: list[str], mode: str) -> str:
    """JSGF for a chunk: "head" takes a non-empty prefix of the tokens,
    "tail" a non-empty suffix."""
    if mode == "head":
        body = tokens[0] + " " + "".join("[ " + t + " " for t in tokens[1:]) + "]" * (len(tokens) - 1)
    else:
        rev = tokens[::-1]
        body = "[ " * (len(rev) - 1) + " ".join(t + " ]" for t in reversed(rev[1:])) + " " + rev[0]
    return f"#JSGF V1.0;\ngrammar chunk;\npublic <s> = {body};\n"


def _decode(decoder, pcm: bytes, search: str, tokens: list[str], mode: str):
    """One chunk: a first pass (forced text, or a grammar letting the acoustic
    model choose where the chunk ends), then the phone pass.

    Returns (kind, words used, payload): "phones" with per-word phone frames,
    "words" with word frames only, or "failed" with the reason.
    """
    try:
        if mode == "all":
            decoder.set_align_text(" ".join(tokens))
        else:
            decoder.add_jsgf_string(search, _grammar(tokens, mode))
            decoder.activate_search(search)
        decoder.start_utt()
        decoder.process_raw(pcm, full_utt=True)
        decoder.end_utt()
        segs = [(sg.word, sg.start_frame, sg.end_frame) for sg in (decoder.seg() or [])]
    except RuntimeError as exc:
        return ("failed", 0, f"word pass: {exc}")
    known = set(tokens)
    found = [sg for sg in segs if sg[0] in known]
    got = [sg[0] for sg in found]
    if not got:
        return ("failed", 0, "no word recognised")
    expected = {"all": tokens, "head": tokens[:len(got)], "tail": tokens[len(tokens) - len(got):]}[mode]
    if got != expected:
        return ("failed", 0, "the word pass did not place every word")
    word_frames = [(sg[1], sg[2] + 1) for sg in found]
    phones = _phone_pass(decoder, pcm, got)
    if phones is None and mode != "all":
        # The phone pass does not always follow a grammar search: force the
        # words the grammar found and try once more.
        try:
            decoder.set_align_text(" ".join(got))
            decoder.start_utt()
            decoder.process_raw(pcm, full_utt=True)
            decoder.end_utt()
            phones = _phone_pass(decoder, pcm, got)
        except RuntimeError:
            phones = None
    if phones is None:
        return ("words", len(got), word_frames)
    return ("phones", len(got), phones)


def _phone_pass(decoder, pcm: bytes, got: list[str]):
    known = set(got)
    try:
        decoder.set_alignment()
        decoder.start_utt()
        decoder.process_raw(pcm, full_utt=True)
        decoder.end_utt()
        alignment = decoder.get_alignment()
        if alignment is None:
            raise RuntimeError("no sub-word alignment")
        words = [(w.name, [(p.name, p.start, p.start + p.duration) for p in w])
                 for w in alignment if w.name in known]
    except RuntimeError:
        return None
    if [w[0] for w in words] != got:
        return None
    return [w[1] for w in words]


def _cover_speech(decoder, pcm, mask, side, kind, used, payload, lo, hi, first):
    """The grammar search may stop early, letting "silence" swallow speech it
    fits poorly.  If much of the chunk's speech lies outside the words found,
    force more words (as many as fit at the speaking rate measured on the
    words found) and keep the first count that aligns."""
    frames = payload if kind == "words" else [(ph[0][1], ph[-1][2]) for ph in payload]
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
    frames = payload if kind == "words" else [(ph[0][1], ph[-1][2]) for ph in payload]
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


def _longest_run(mask: np.ndarray) -> int:
    """Length of the longest run of True."""
    if not mask.any():
        return 0
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    return int((edges[1::2] - edges[0::2]).max())


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
        frames = payload if kind == "words" else [(ph[0][1], ph[-1][2]) for ph in payload]
        if mode == "head":
            out.append((first + lo, first + lo + used, a, b, kind, payload))
            a, lo = a + frames[-1][1] * FRAME, lo + used
        else:
            out.append((first + hi - used, first + hi, a, b, kind, payload))
            b, hi = a + frames[0][0] * FRAME, hi - used
    if lo < hi:
        out.append((first + lo, first + hi, a, b, "failed", "forced alignment failed"))
    return out


# ---------------------------------------------------------------------------

def _estimate(phones_per_word: Sequence[Sequence[str]], spans: list[tuple[float, float]]):
    """Spread words over speech spans in proportion to their typical length.
    Returns per word a list of (phone, start, end)."""
    weights = [[typical_duration(p) for p in ph] for ph in phones_per_word]
    total = sum(sum(w) for w in weights) or 1.0
    span_total = sum(b - a for a, b in spans) or 1e-3

    def at(x: float) -> float:  # a clock that runs only during speech
        for a, b in spans:
            if x <= b - a:
                return a + x
            x -= b - a
        return spans[-1][1]

    out = []
    clock = 0.0
    for ph, w in zip(phones_per_word, weights):
        cur = []
        for p, d in zip(ph, w):
            d = d / total * span_total
            cur.append((p, at(clock), at(clock + d)))
            clock += d
        out.append(cur)
    return out


def _speech_spans(mask: np.ndarray, start: float, end: float) -> list[tuple[float, float]]:
    a, b = int(start / FRAME), int(math.ceil(end / FRAME))
    sub = mask[a:b]
    spans = []
    i = 0
    while i < len(sub):
        if sub[i]:
            j = i
            while j < len(sub) and sub[j]:
                j += 1
            spans.append(((a + i) * FRAME, (a + j) * FRAME))
            i = j
        else:
            i += 1
    return spans or [(start, end)]


def _pool(settings: AlignSettings):
    import multiprocessing

    n = settings.workers or os.cpu_count() or 1
    # fork shares the loaded modules and costs nothing to start; where it is
    # not available (Windows) or unsafe (macOS), everything runs in-process.
    if n < 2 or "fork" not in multiprocessing.get_all_start_methods() or sys.platform == "darwin":
        return None
    return ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("fork"))


class _Inline:
    """Stands in for a process pool: runs the call at once."""

    class _Done:
        def __init__(self, value):
            self._value = value

        def result(self):
            return self._value

    def submit(self, fn, *args):
        return self._Done(fn(*args))

    def shutdown(self):
        pass


def _whole(audio: Audio, prons: list[list[str]], first: int, t0: float, t1: float, settings: AlignSettings):
    """Forced alignment of words ``first..`` to the audio t0..t1 in one pass."""
    decoder = _decoder(prons, first, settings)
    tokens = [f"w{first + i}" for i in range(len(prons))]
    return _decode(decoder, audio.pcm16(t0, t1), "all", tokens, "all")


def align(audio: Audio, words_phones: Sequence[Sequence[str]], pause_hints: Sequence[float] | None = None,
          texts: Sequence[str] | None = None, sources: Sequence[str] | None = None,
          settings: AlignSettings | None = None,
          progress: Callable[[float], None] | None = None) -> Alignment:
    """Align words (each given as its ARPAbet phones) to the audio.

    Every word is placed: words that could not be aligned acoustically are
    placed by the fallback and marked ``estimated``.  Raises
    :class:`AudioError` if the audio holds no speech and
    :class:`TranscriptError` if there are no words.  ``pause_hints`` (the
    script's punctuation) are accepted for callers' convenience; the cuts are
    chosen acoustically.
    """
    settings = settings or AlignSettings()
    n = len(words_phones)
    if n == 0:
        raise TranscriptError("the transcript has no words to align")
    texts = list(texts or [f"word{i}" for i in range(n)])
    sources = list(sources or [""] * n)
    prons = [list(p) for p in words_phones]
    if audio.duration < 0.1:
        raise AudioError(f"the audio is too short to hold speech ({audio.duration:.3f} s; "
                         "a line needs at least 0.1 s)")
    levels = frame_levels(audio)
    mask, _ = speech_mask(levels, audio)
    if not mask.any():
        raise AudioError(
            f"the audio holds no speech (loudest level {float(levels.max()):.0f} dBFS): "
            "check that the right sound is selected and that it is not muted")
    result: list[list[tuple[str, float, float]] | None] = [None] * n
    est = [False] * n
    notes: list[str] = []

    def place(kind, payload, wa, wb, t0, t1):
        if kind == "phones":
            for k, frames in enumerate(payload):
                result[wa + k] = [(p, t0 + a * FRAME, t0 + b * FRAME) for p, a, b in frames]
        elif kind == "words":
            for k, (a, b) in enumerate(payload):
                result[wa + k] = _estimate([prons[wa + k]], [(t0 + a * FRAME, t0 + b * FRAME)])[0]
                est[wa + k] = True
            notes.append(f"{t0:.2f}-{t1:.2f} s: phone pass failed; word times kept, phones estimated")
        else:
            todo = list(range(wa, wb))
            for wi, ph in zip(todo, _estimate([prons[wi] for wi in todo], _speech_spans(mask, t0, t1))):
                result[wi] = ph
                est[wi] = True
            notes.append(f"{t0:.2f}-{t1:.2f} s: could not be aligned ({payload}); "
                         f"{len(todo)} word(s) placed by estimate")

    done = False
    pool = _pool(settings) if audio.duration > settings.split_above else None
    if pool is not None:
        done = _align_halves(audio, prons, settings, pool, place)
    if not done:
        kind, used, payload = _whole(audio, prons, 0, 0.0, audio.duration, settings)
        if kind != "failed":
            place(kind, payload, 0, n, 0.0, audio.duration)
            done = True
    if not done:
        _align_chunked(audio, prons, mask, settings, place, result, progress)
    if progress:
        progress(1.0)

    words: list[AlignedWord] = []
    phones: list[AlignedPhone] = []
    for wi in range(n):
        ph = _clean(result[wi])
        words.append(AlignedWord(texts[wi], ph[0][1], ph[-1][2], prons[wi], sources[wi], est[wi]))
        for p, a, b in ph:
            phones.append(AlignedPhone(p, a, b, wi, est[wi]))
    warnings = []
    extra = unspoken_speech(mask, words)
    if extra:
        seconds, first, last = extra
        warnings.append(f"{seconds:.1f} s of speech between {first:.2f} s and {last:.2f} s is not covered by "
                        "the transcript's words: is the transcript complete? (that part stays at rest)")
    return Alignment(words, phones, audio.duration, warnings + notes, warnings)


def unspoken_speech(mask: np.ndarray, words: list[AlignedWord], margin: float = 0.2
                    ) -> tuple[float, float, float] | None:
    """Speech (``mask``, one flag per :data:`FRAME`) that no word lies on,
    when there is much of it (over 0.5 s and a quarter of all speech): a
    transcript that lacks part of what is said.  (seconds, first, last)."""
    t = np.arange(len(mask)) * FRAME
    covered = np.zeros(len(mask), bool)
    for w in words:
        covered |= (t >= w.start - margin) & (t <= w.end + margin)
    extra = mask & ~covered
    seconds = float(extra.sum()) * FRAME
    if seconds <= 0.5 or seconds <= 0.25 * float(mask.sum()) * FRAME:
        return None
    idx = np.flatnonzero(extra)
    return seconds, float(t[idx[0]]), float(t[idx[-1]] + FRAME)


def _split_words(audio: Audio, prons: list[list[str]], settings: AlignSettings) -> tuple[int, float] | None:
    """Where to cut a long clip in two, and how many words go before the cut.

    A quick forced word pass over the whole clip (scoring every second frame
    only) finds the words; the cut goes in the middle of the pause between
    two words nearest the middle of the speech.  Returns (words before the
    cut, cut time) or None if the pass fails."""
    decoder = _decoder(prons, 0, settings, ds=2)
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


def _clean(ph: list[tuple[str, float, float]]) -> list[tuple[str, float, float]]:
    """pocketsphinx may report a phone of zero frames; give it a sliver."""
    out = []
    for p, a, b in ph:
        if out and a < out[-1][2]:
            a = out[-1][2]
        out.append((p, a, max(b, a + 0.005)))
    return out


def check_transcript_matches(alignment: Alignment, max_estimated_share: float = 0.5) -> None:
    """Raise :class:`AlignmentError` when most of the words could only be
    placed by estimate: the transcript probably belongs to other audio."""
    share = alignment.n_estimated / max(1, len(alignment.phones))
    if share > max_estimated_share and len(alignment.words) > 3:
        raise AlignmentError(
            f"{share:.0%} of the phonemes could not be aligned to the audio: "
            "does the transcript belong to this recording?")
