"""The aligner's front end: a written transcript, not phones.

:func:`align_audio` normalises the transcript (:mod:`..language`),
pronounces every word in the lexicon's language and aligns the phones to
the audio with :func:`.align` (the English acoustic model, each phone of
another language mapped to the English phone of the nearest mouth);
the words the aligner cannot use (another script, symbols) are left out and
said so in the alignment's notes and warnings.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from concurrent.futures.process import BrokenProcessPool

import numpy as np

from .. import audio as audio_mod
from ..audio import Audio
from ..errors import AlignmentError
from ..language import Lexicon, Pronunciation, describe_skipped, normalize, skipped_words
from .core import align, check_transcript_matches
from .model import FRAME, AlignSettings, Alignment
from .speech import frame_levels, speech_mask
from .tail import transcript_end
from .verify import edit_path, verify


def align_audio(snd: Audio, text: str, lexicon: Lexicon | None = None,
                settings: AlignSettings | None = None,
                progress: Callable[[float], None] | None = None, check_take: bool = True) -> Alignment:
    """Normalise ``text``, pronounce every word and align it to ``snd``;
    with ``check_take``, then check the transcript against the take
    (:func:`.verify.verify`: words not said, speech not scripted)."""
    lexicon = lexicon or Lexicon()
    settings = settings or AlignSettings()
    words = normalize(text, lexicon.language)
    prons = [lexicon.pronounce(w) for w in words]
    phones = [p.aligned or p.phones for p in prons]

    def run(clip: Audio, report=None) -> Alignment:
        try:
            return align(clip, phones, [w.pause_after for w in words], [w.text for w in words],
                         [p.source for p in prons], settings, report)
        except (BrokenProcessPool, MemoryError):
            raise AlignmentError(f"the aligner ran out of memory (or a worker process was stopped) on "
                                 f"{snd.duration / 60:.1f} minutes of audio: split the recording into shorter "
                                 "lines") from None

    al = run(snd, progress)
    if check_take:
        english = lexicon.language.is_english
        verify(snd, al, settings, english=english)
        end = _script_ends_early(snd, al, phones, settings)
        if end is not None:
            # Speech after the transcript's end (:mod:`.tail`): the transcript is aligned up to where
            # its last word ends, and the take checked again over the whole clip.
            ended = run(snd.head(end + TAIL_MARGIN))
            ended.duration = snd.duration
            verify(snd, ended, settings, english=english)
            if not _said_at_the_end(al, ended, end):
                al = ended
    check_transcript_matches(al)
    _show(al, prons)
    skipped = skipped_words(text, lexicon.language)
    if skipped:
        n = len(skipped)
        warning = (f"{n} word{'s' if n > 1 else ''} of the transcript left out, the aligner cannot use "
                   f"{'them' if n > 1 else 'it'}: {describe_skipped(skipped)}")
        al.notes.insert(0, warning)
        al.warnings.insert(0, warning)
    return al


#: Room (s) left after the transcript's last word when speech follows it (:mod:`.tail`).
TAIL_MARGIN = 0.1
#: The transcript ends early only where its last word moves back by more than this (s).
TAIL_SHIFT = 0.1
#: Speech after the script pulls its last few words: an early end moves at most this many (speech
#: cut from the middle of a transcript leaves its last words at the clip's end, where the loop of
#: :mod:`.tail` may take them too).
TAIL_WORDS = 3
#: The words an early end moves are heard at the clip's end in this share of their phones: they
#: were said there, and the first alignment stands.
TAIL_HEARD = 0.5
#: How far (s) past the loop's start the transcript's end may reach, to the next pause.
TAIL_REACH = 0.3


def _script_ends_early(snd: Audio, al: Alignment, phones: list[list[str]], settings: AlignSettings) -> float | None:
    """Where the transcript ends, when the check of the take found unscripted
    speech and speech after the transcript's end pulls its last word more than
    :data:`TAIL_SHIFT` s later (:func:`.tail.transcript_end`); else None."""
    script = [w for w in al.words if w.spoken and not w.recognized]
    if not al.unscripted or not script:
        return None
    end = transcript_end(snd, phones, settings)
    if end is None or end > max(w.end for w in script) - TAIL_SHIFT:
        return None
    if sum(w.end > end + TAIL_SHIFT for w in script) > TAIL_WORDS:
        return None
    # The loop may take the last word's fading end: up to TAIL_REACH s more, to the next pause.
    mask, _ = speech_mask(frame_levels(snd), snd)
    first, last = int(round(end / FRAME)), int(round((end + TAIL_REACH) / FRAME))
    pause = np.flatnonzero(~mask[first:last])
    return (first + pause[0]) * FRAME if len(pause) else end + TAIL_REACH - TAIL_MARGIN


def _said_at_the_end(first: Alignment, ended: Alignment, end: float) -> bool:
    """Whether the words an early ``end`` moves are heard at the end of the
    clip after all: :data:`TAIL_HEARD` of their phones matched, in order, by
    the last phones recognised there (twice as many).  Speech cut from the
    middle of a transcript leaves its last words at the clip's end, where
    the phone loop of :mod:`.tail` may take them too."""
    moved = [p for w in first.words if w.spoken and not w.recognized and w.end > end + TAIL_SHIFT for p in w.phones]
    heard = [p for w in ended.words if w.recognized and w.start >= end for p in w.phones][-2 * len(moved):]
    if not moved or not heard:
        return False
    matched = sum(same for _, _, same in edit_path(moved, heard))
    return matched >= TAIL_HEARD * len(moved)


def _show(al: Alignment, prons: list[Pronunciation]) -> None:
    """Words aligned by stand-in phones (:attr:`.Pronunciation.aligned`)
    get back the phones their mouth shows."""
    by_word: dict[int, list] = {}
    for p in al.phones:
        by_word.setdefault(p.word_index, []).append(p)
    for wi, pron in enumerate(prons):
        if not pron.aligned:
            continue
        al.words[wi].phones = list(pron.phones)
        got = by_word.get(wi, [])
        if [p.phone for p in got] == pron.aligned:
            for p, shown in zip(got, pron.phones):
                p.phone = shown
        else:   # the aligner changed the word's phones (a stretch placed by estimate): undo each stand-in alone
            back = {a: s for a, s in zip(pron.aligned, pron.phones) if a != s}
            for p in got:
                p.phone = back.get(p.phone, p.phone)


def align_file(path: str | os.PathLike, text: str, **kw) -> Alignment:
    """:func:`align_audio` on an audio file."""
    return align_audio(audio_mod.load(path), text, **kw)
