"""The aligner's entry point: :func:`align`."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace


from ..audio import Audio
from ..errors import AlignmentError, AudioError, TranscriptError
from .boundaries import shift_boundaries
from .bursts import refine_stops
from .fillers import mark, restore
from .chunks import _align_chunked
from .decoding import _whole
from .onsets import FROM_IPA, place_onsets
from .estimate import _clean, _estimate
from .pieces import _align_pieces
from .reduced import shorten_reduced
from .model import FRAME, AlignedPhone, AlignedWord, AlignSettings, Alignment
from .parallel import _pool
from .stream import align_stream
from .speech import _speech_spans, speech_or_refuse, unspoken_speech


#: A clip up to this long (s) whose forced pass finds no path is passed once more with beams of
#: WIDEST_BEAM before it is cut into chunks: a short hoarse line said as written ("have a cold so
#: i probably sound quite different than", 2.8 s) has no path at 1e-200 and one at 1e-300.
WIDEST_UP_TO, WIDEST_BEAM = 10.0, 1e-300


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
    prons = mark(words_phones, texts)
    if audio.duration < 0.1:
        raise AudioError(f"the audio is too short to hold speech ({audio.duration:.3f} s; "
                         "a line needs at least 0.1 s)")
    _levels, mask = speech_or_refuse(audio)
    result: list[list[tuple[str, float, float]] | None] = [None] * n
    est = [False] * n
    fit: list[float | None] = [None] * n
    notes: list[str] = []

    def place(kind, payload, wa, wb, t0, t1):
        if kind == "phones":
            for k, frames in enumerate(payload):
                result[wa + k] = [(p, t0 + a * FRAME, t0 + b * FRAME) for p, a, b, _ in frames]
                fit[wa + k] = sum(score for *_, score in frames) / max(1, sum(b - a for _, a, b, _ in frames))
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
    if audio.duration > settings.stream_above:
        align_stream(audio, prons, mask, settings, place, progress)
        done = True
    pool = _pool(settings) if not done and audio.duration > settings.split_above else None
    if pool is not None:
        done = _align_pieces(audio, prons, settings, pool, place)
    if not done:
        kind, used, payload = _whole(audio, prons, 0, 0.0, audio.duration, settings, mask)
        if kind == "failed" and audio.duration <= WIDEST_UP_TO:
            # The right path can fall out of even these beams on a hard voice: once more, wider.
            wide = replace(settings, beam=WIDEST_BEAM, pbeam=WIDEST_BEAM, wbeam=WIDEST_BEAM)
            kind, used, payload = _whole(audio, prons, 0, 0.0, audio.duration, wide, mask)
        if kind != "failed":
            place(kind, payload, 0, n, 0.0, audio.duration)
            done = True
    if not done:
        _align_chunked(audio, prons, mask, settings, place, result, progress)
    if progress:
        progress(1.0)

    restore(result, prons)
    # Words read from IPA (other languages) have their own corrections; English ones keep theirs.
    from_ipa = [s in FROM_IPA for s in sources]
    refine_stops(audio, result, est, from_ipa)
    shorten_reduced(result, est)
    if any(from_ipa):
        place_onsets(audio, result, est, from_ipa)
        shift_boundaries(audio, result, est, from_ipa=from_ipa)
    else:
        shift_boundaries(audio, result, est)
    words: list[AlignedWord] = []
    phones: list[AlignedPhone] = []
    for wi in range(n):
        ph = _clean(result[wi])
        said = [p for p, _, _ in ph]     # a pronunciation of the word's own the aligner chose by the sound
        chosen = said if not est[wi] and said in getattr(prons[wi], "variants", []) else prons[wi]
        words.append(AlignedWord(texts[wi], ph[0][1], ph[-1][2], list(chosen), sources[wi], est[wi],
                                 fit=None if est[wi] else fit[wi]))
        for p, a, b in ph:
            phones.append(AlignedPhone(p, a, b, wi, est[wi]))
    warnings = []
    extra = unspoken_speech(mask, words)
    if extra:
        seconds, first, last = extra
        warnings.append(f"{seconds:.1f} s of speech between {first:.2f} s and {last:.2f} s is not covered by "
                        "the transcript's words: is the transcript complete? (that part stays at rest)")
    return Alignment(words, phones, audio.duration, warnings + notes, warnings)


#: How well a transcript fits its take (:func:`fit`, English lines): a transcript said as written
#: fits at -10 to -40 per frame, down to -55 on a hoarse voice sped up 1.5 times
#: (``bench/false_alarms.py``); another sentence's transcript at -35 to -90 (TIMIT, most
#: below -50).  Below this the line is animated with the words given, and a warning asks whether
#: the transcript belongs to the recording.
FIT_WARNED = -65.0
#: At least this many frames of the transcript's phones are needed to judge the fit.
FIT_FRAMES = 50


def fit(alignment: Alignment) -> tuple[float, int] | None:
    """(the transcript's fit per frame, frames): the fit of its words aligned
    acoustically (:attr:`.model.AlignedWord.fit`), weighed by their frames;
    None when no word was."""
    num = den = 0.0
    for w in alignment.script:
        if w.fit is not None and w.spoken:
            frames = max(1.0, (w.end - w.start) / FRAME)
            num += w.fit * frames
            den += frames
    return (num / den, int(den)) if den else None


def check_transcript_matches(alignment: Alignment, max_estimated_share: float = 0.5,
                             judge_fit: bool = True) -> None:
    """Raise :class:`AlignmentError` when nothing fits: most of the phonemes
    could only be placed by estimate, or most of the transcript's words
    were not heard (:mod:`.verify`).  With ``judge_fit`` (English lines, where
    the acoustic model is the speech's own; words read from IPA are left out
    of it), a transcript whose phones fit the audio poorly (:data:`FIT_WARNED`)
    is animated with its words and warned of, once."""
    share = alignment.n_estimated / max(1, len(alignment.phones))
    if share > max_estimated_share and len(alignment.words) > 3:
        raise AlignmentError(
            f"{share:.0%} of the phonemes could not be aligned to the audio: "
            "does the transcript belong to this recording?")
    script = alignment.script
    unheard = sum(not w.spoken for w in script) / max(1, len(script))
    if unheard > max_estimated_share and len(script) > 3:
        raise AlignmentError(
            f"{unheard:.0%} of the transcript's words could not be aligned to the audio nor heard in it: "
            "does the transcript belong to this recording?")
    if not judge_fit:
        return
    own = Alignment([w for w in script if w.source not in FROM_IPA], [], alignment.duration)
    got = fit(own)
    if got is None or got[1] < FIT_FRAMES or got[0] >= FIT_WARNED:
        return
    said = (f"the transcript's sounds fit the audio poorly ({got[0]:.0f} per frame; a transcript said as "
            f"written fits above {FIT_WARNED:.0f}): does it belong to this recording? Animated with its words")
    alignment.notes.append(said)
    alignment.warnings.append(said)
