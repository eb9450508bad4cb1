"""Speech without a script: the words recognised, then their phones aligned.

With no transcript, what was said is recognised with pocketsphinx's bundled
US English acoustic model, language model and dictionary.  The audio is cut
at its pauses into chunks of at most :attr:`AlignSettings.max_chunk` seconds
(:func:`.chunks.plan_chunks`), so memory stays bounded whatever the length;
each chunk is decoded with the language model (a search pruned hard: see
:data:`DECODER_OPTIONS`), then its phones are aligned to the words found,
frame by frame, in a second pass.  The chunks are shared between two processes when
there are several.

Recognition makes mistakes a transcript would not (a similar-sounding word,
a short word dropped), but the mouth shapes follow the sounds, which the
recogniser gets mostly right; where its best guess misses a /p b m/ that the
other words it weighed close the lips for, they close (:mod:`.unsure`).
Recognised words carry ``recognized = True``.
"""

from __future__ import annotations

import re
from collections.abc import Callable

import numpy as np

from ..audio import Audio
from .chunks import plan_chunks
from .decoding import phone_alignment
from .estimate import _clean, _estimate
from .model import FRAME, AlignedPhone, AlignedWord, AlignSettings, Alignment
from .parallel import _pool
from .speech import speech_or_refuse
from . import unsure

#: The recogniser's search.  Every frame is scored (``ds`` 1): scoring every
#: second one took 0.12 x real time against 0.15 on bench/offscript.py's
#: clips (the second, alignment pass scores every frame anyway) but heard worse
#: (bench/no_transcript.py: lips closed at 0.40 of /p b m/ on the natural
#: monologues against 0.52, 0.64 against 0.68 on the voice-quality clips and
#: sonnets, 0.89 against 0.91 on TIMIT; pauses at rest 0.83 and 0.71 against
#: 0.92 and 0.87).  It prunes harder than pocketsphinx's defaults
#: (``maxhmmpf``, ``maxwpf``) and has no phone lookahead (``pl_window``),
#: which carries state from one utterance to the next (see :data:`_RESET`).
#: The language model weighs less than pocketsphinx's default (``lw`` 4
#: against 6.5): the words heard follow the sounds more closely, which is what
#: the mouth shows (on the spontaneous speech of bench/offscript.py the lips
#: close at 9 of 25 /p b m/ where they closed at 4, and the event score goes
#: from 0.88 to 0.95; read TIMIT sentences stay at 0.98); the search this
#: widens is held by ``maxhmmpf`` and ``maxwpf``, so it costs no more time.
DECODER_OPTIONS = dict(ds=1, fwdflat=False, bestpath=False, lw=4.0, maxhmmpf=500, maxwpf=3,
                       beam=1e-40, wbeam=1e-30, pbeam=1e-40, cmn="batch", pl_window=0)

#: The search of the checks of a take against its script (:mod:`.verify`),
#: which recognise the speech a transcript's words leave out: every second
#: frame scored.  Their thresholds (how many words make speech heard,
#: :data:`.verify.MIN_HEARD_WORDS`) were set on what this search hears, and
#: it hears more words in unscripted speech (bench/offscript.py), so it stays.
CHECK_OPTIONS = dict(DECODER_OPTIONS, ds=2)

_VARIANT = re.compile(r"\(\d+\)$")
_loaded: dict = {}   # {check: [decoder, its language-model search]}, the one last used


def _decoder(check: bool = False):
    """The recogniser (with ``check``, the checks' one: :data:`CHECK_OPTIONS`),
    loaded once (the language model takes 0.4 s); the worker processes are
    forked with it loaded and use their own copy.  Each holds the language
    model (90 MB), so a process keeps one: loading the other frees it (a
    batch of lines with and without transcripts stays within its memory)."""
    import pocketsphinx

    if check not in _loaded:
        _loaded.clear()
        options = CHECK_OPTIONS if check else DECODER_OPTIONS
        decoder = pocketsphinx.Decoder(samprate=16000, loglevel="FATAL", **options)
        _loaded[check] = [decoder, decoder.current_search()]
    return _loaded[check]


def _is_word(name: str) -> bool:
    return not (name.startswith("<") or name.startswith("[") or name.startswith("+"))


#: 0.1 s of faint noise, decoded before every chunk.  pocketsphinx carries
#: state from one utterance to the next (a chunk after a 1.00 s chunk and
#: after a 1.01 s one is heard differently; the first chunk a fresh decoder
#: hears, differently again), and resetting its features (``reinit_feat``)
#: alone does not undo it; after both, a chunk is heard alike whatever came
#: before it, in whichever process and order the chunks are recognised.
_RESET = (np.random.default_rng(0).normal(0.0, 30.0, 1600)).astype("<i2").tobytes()


def _recognize_chunk(pcm: bytes, check: bool = False, fewest: int = 0
                     ) -> list[tuple[str, list[tuple[str, int, int]], bool]]:
    """The words of one chunk: (text, [(phone, first frame, end frame)],
    phones estimated); none where fewer than ``fewest`` words are heard
    (their phones are then not aligned).  Frames count from the chunk's
    start; what came before it does not count (:data:`_RESET`)."""
    decoder, search = _decoder(check)
    try:
        decoder.activate_search(search)  # the alignment pass of the chunk before left its own search active
        decoder.reinit_feat()
        decoder.start_utt()
        decoder.process_raw(_RESET, full_utt=True)
        decoder.end_utt()
        decoder.start_utt()
        decoder.process_raw(pcm, full_utt=True)
        decoder.end_utt()
    except RuntimeError:
        return []
    segs = [(sg.word, sg.start_frame, sg.end_frame + 1) for sg in (decoder.seg() or []) if _is_word(sg.word)]
    if not segs or len(segs) < fewest:
        return []
    # The other words the recogniser weighed, for the lips it was unsure of (not for the checks).
    weight = None if check else unsure.labial_weight(decoder, len(pcm) // 320 + 1)
    try:
        words = [(name, phones) for name, phones in phone_alignment(decoder, pcm) if _is_word(name)]
    except RuntimeError:
        words = []
    if [w[0] for w in words] == [s[0] for s in segs]:
        return unsure.with_closures([(_VARIANT.sub("", name), phones, False) for name, phones in words], weight)
    # The phone pass failed: the word times stay, phones by estimate.
    out = []
    for name, a, b in segs:
        pron = (decoder.lookup_word(name) or "").split()
        if not pron:
            continue
        ph = _estimate([pron], [(a * FRAME, b * FRAME)])[0]
        out.append((_VARIANT.sub("", name), [(p, int(round(s / FRAME)), int(round(e / FRAME))) for p, s, e in ph],
                    True))
    return unsure.with_closures(out, weight)


_SHARED: dict = {}


def _chunk_shared(key: int, t0: float, t1: float, check: bool, fewest: int = 0):
    return _recognize_chunk(_SHARED[key].pcm16(t0, t1, floor=False), check, fewest)


def recognize_spans(audio: Audio, spans: list[tuple[float, float]], settings: AlignSettings | None = None,
                    progress: Callable[[float], None] | None = None, check: bool = False, fewest: int = 0
                    ) -> tuple[list[AlignedWord], list[AlignedPhone]]:
    """Recognise the speech of each (start, end) span of ``audio`` (s), with
    the checks' search when ``check`` (:data:`CHECK_OPTIONS`).  Returns the
    words (``recognized``) and their phones, in time order; a phone's
    ``word_index`` counts in the returned words.  ``fewest``: a span in which
    fewer words are heard returns none, and its phones are not aligned (a
    caller that counts words heard has no use for them)."""
    settings = settings or AlignSettings()
    spans = [(a, b) for a, b in spans if b - a >= 0.05]
    if not spans:
        return [], []
    _decoder(check)  # loaded before the workers are forked, which share it
    pool = _pool(settings) if len(spans) > 1 else None
    key = id(audio)
    _SHARED[key] = audio
    try:
        if pool is not None:
            futures = [pool.submit(_chunk_shared, key, a, b, check, fewest) for a, b in spans]
            results = []
            for k, f in enumerate(futures):
                results.append(f.result())
                if progress:
                    progress((k + 1) / len(spans))
        else:
            results = []
            for k, (a, b) in enumerate(spans):
                results.append(_chunk_shared(key, a, b, check, fewest))
                if progress:
                    progress((k + 1) / len(spans))
    finally:
        if pool is not None:
            pool.shutdown()
        del _SHARED[key]
    words: list[AlignedWord] = []
    phones: list[AlignedPhone] = []
    for (t0, t1), found in zip(spans, results):
        for text, ph, est in found:
            scores = [(rest[0], b - a) for _, a, b, *rest in ph if rest]
            fit = sum(x for x, _ in scores) / max(1, sum(n for _, n in scores)) if scores and not est else None
            ph = _clean([(p, min(t1, t0 + a * FRAME), min(t1, t0 + b * FRAME)) for p, a, b, *_ in ph])
            wi = len(words)
            words.append(AlignedWord(text, ph[0][1], ph[-1][2], [p for p, _, _ in ph], "recognized", est,
                                     recognized=True, fit=fit))
            phones.extend(AlignedPhone(p, a, b, wi, est) for p, a, b in ph)
    return words, phones


def speech_chunks(mask: np.ndarray, settings: AlignSettings, duration: float) -> list[tuple[float, float]]:
    """The clip's speech cut at its pauses, as (start, end) s."""
    return [(c.start, c.end) for c in plan_chunks(mask, settings, duration)]


def recognize(audio: Audio, settings: AlignSettings | None = None,
              progress: Callable[[float], None] | None = None) -> Alignment:
    """What ``audio`` says, recognised and aligned: an :class:`Alignment`
    whose words all carry ``recognized = True``."""
    settings = settings or AlignSettings()
    _levels, mask = speech_or_refuse(audio)
    words, phones = recognize_spans(audio, speech_chunks(mask, settings, audio.duration), settings, progress)
    if not words:
        note = "no transcript, and no words were recognised in the audio: the mouth stays at rest"
        return Alignment(words, phones, audio.duration, [note], [note])
    heard = len(words)
    words, phones = with_hesitations(audio, mask, words, phones)
    note = (f"no transcript: the words were recognised from the audio ({heard} word{'s' if heard != 1 else ''}"
            + (f"; {len(words) - heard} stretch{'es' if len(words) - heard != 1 else ''} of speech with no word "
               "heard in it shown as 'uh'" if len(words) > heard else "")
            + "); give a transcript for exact words and timing")
    return Alignment(words, phones, audio.duration, [note], [])


#: Speech the recogniser hears no word in, at least this long (s) and loud (within this many dB of
#: the voice), is a hesitation or a word it missed, and the mouth says "uh" through it rather than
#: rest: the hoarse monologue's "uh"s (``bench/no_transcript.py``: vowels open 0.950 -> 0.981 on
#: the natural clips, the other groups unchanged).  Shorter or quieter, it is a breath, a click or
#: a word's decay, and the mouth rests (at 0.1 s a pause of the hoarse monologue lost its rest).
HESITATION, HESITATION_DB = 0.25, 15.0
#: ... and this far (s) from every word heard.
HESITATION_MARGIN = 0.03


def with_hesitations(audio: Audio, mask: np.ndarray, words: list[AlignedWord], phones: list[AlignedPhone]
                     ) -> tuple[list[AlignedWord], list[AlignedPhone]]:
    """``words`` and ``phones`` (recognised) with an "uh" (AH) on every
    stretch of loud speech no word was heard in (:data:`HESITATION`), in
    time order; a phone's ``word_index`` counts in the returned words."""
    from .speech import covered_by, frame_levels, runs, voice_level

    n = len(mask)
    band = np.full(n, -np.inf)
    levels = frame_levels(audio, emphasis=True)[:n]
    band[:len(levels)] = levels
    near = covered_by(words, n, HESITATION_MARGIN)
    loud = band >= voice_level(band, covered_by(words, n)) - HESITATION_DB
    found = [AlignedWord("uh", i * FRAME, j * FRAME, ["AH"], "recognized", True, recognized=True)
             for i, j in runs(mask & loud & ~near).tolist() if (j - i) * FRAME >= HESITATION]
    if not found:
        return words, phones
    own: dict[int, list[AlignedPhone]] = {}
    for p in phones:
        own.setdefault(p.word_index, []).append(p)
    merged = sorted([(w, own.get(k, [])) for k, w in enumerate(words)]
                    + [(w, [AlignedPhone("AH", w.start, w.end, -1, True)]) for w in found], key=lambda x: x[0].start)
    return ([w for w, _ in merged],
            [AlignedPhone(p.phone, p.start, p.end, k, p.estimated) for k, (_, ph) in enumerate(merged) for p in ph])
