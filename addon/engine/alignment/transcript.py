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
from dataclasses import replace
from collections.abc import Callable, Sequence
from concurrent.futures.process import BrokenProcessPool

from .. import audio as audio_mod
from ..audio import Audio
from ..errors import AlignmentError, LipSyncError
from ..language import (Lexicon, Pronunciation, assimilation, describe_skipped, normalize, skipped_words,
                        stage_direction_gaps)
from .core import align, check_transcript_matches
from .edges import CUT_ROUNDS, edges, heard_in, left_out, said_at_the_end
from .model import AlignSettings, Alignment, Variants
from .held import said_otherwise
from .refine import model_for, refine_alignment
from . import tempo
from .room import lay_out, room
from .verify import verify


def align_audio(snd: Audio, text: str, lexicon: Lexicon | None = None,
                settings: AlignSettings | None = None,
                progress: Callable[[float], None] | None = None, check_take: bool = True) -> Alignment:
    """Normalise ``text``, pronounce every word and align it to ``snd``;
    with ``check_take``, then check the transcript against the take
    (:func:`.verify.verify`: words not said, speech not scripted)."""
    lexicon = lexicon or Lexicon()
    settings = settings or AlignSettings()
    words = normalize(text, lexicon.language)
    directions = stage_direction_gaps(text, lexicon.language)
    prons = always_said([lexicon.pronounce(w) for w in words], lexicon.language.code)
    phones = said_as(prons, lexicon.language.code)

    def run(clip: Audio, report=None, stand_in: dict[int, list[str]] | None = None) -> Alignment:
        """The transcript aligned to ``clip``; speech too fast for the aligner's frames on a slowed
        copy too (:mod:`.tempo`), the better of the two kept."""
        aligned = [(stand_in or {}).get(k, ph) for k, ph in enumerate(phones)]

        def once(audio: Audio, progress=None) -> Alignment:
            try:
                return align(audio, aligned, [w.pause_after for w in words], [w.text for w in words],
                             [p.source for p in prons], settings, progress)
            except (BrokenProcessPool, MemoryError):
                raise AlignmentError(f"the aligner ran out of memory (or a worker process was stopped) on "
                                     f"{snd.duration / 60:.1f} minutes of audio: split the recording into "
                                     "shorter lines") from None

        first = once(clip, report)
        if clip.duration > tempo.LONGEST or not tempo.too_fast(first):
            return first
        slow = tempo.scaled(once(tempo.slowed(clip)), tempo.SLOWER, clip.duration)
        return slow if tempo.better(first, slow) else first

    english = lexicon.language.is_english

    def again(clip: Audio, stand_in: dict[int, list[str]] | None = None,
              cut: Sequence[tuple[float, float]] = ()) -> Alignment | None:
        """The transcript aligned to ``clip`` (``snd`` with stretches silenced; the words ``stand_in``
        with other phones standing in for theirs, :mod:`.room`) and the take checked again over the
        whole of ``snd`` (``cut``: the stretches silenced as speech cut from it); None where the
        transcript cannot be aligned to it."""
        try:
            second = run(clip, stand_in=stand_in)
        except LipSyncError:
            return None
        second.duration = snd.duration
        if stand_in:
            lay_out(second, {k: phones[k] for k in stand_in})
        verify(snd, second, settings, english=english, left_out=cut, directions=directions)
        return second

    al = run(snd, progress)
    # A vowel held for seconds and said otherwise than the dictionary says (:mod:`.held`).
    al, wider = said_otherwise(snd, al, phones, lambda stand_in: run(snd, stand_in=stand_in),
                               own={k for k, p in enumerate(prons) if not p.aligned})
    for k, ph in wider.items():
        phones[k] = ph
    if check_take:
        verify(snd, al, settings, english=english, directions=directions)
        clip = snd
        bounds = edges(snd, al, phones, settings, held=wider)
        if bounds is not None:
            # Speech before or after the script (:mod:`.edges`): the transcript is aligned to the
            # stretch between its edges, unless its last words were said at the clip's end after all.
            inner = snd.within(*bounds)
            second = again(inner)
            if second is not None and (bounds[1] >= snd.duration or not said_at_the_end(al, second, bounds[1])):
                al, clip = second, inner
        cut: list[tuple[float, float]] = []
        for _ in range(CUT_ROUNDS):
            # Speech left out between the script's words (:func:`.edges.left_out`): the transcript is
            # aligned with it silenced too, so the words around it keep to their own speech.  Then once
            # more with that speech silenced, for a second cut the first search's one loop left.
            more = left_out(clip if cut else snd, al, phones, settings, known=cut, held=wider)
            if not more:
                break
            quiet = clip.silenced(more)
            second = again(quiet, cut=cut + more)
            if second is None or not heard_in(second, more):
                break
            al, clip, cut = second, quiet, cut + more
        stand_in = room(clip, al, phones, settings)
        if stand_in:
            # Words longer than the speech they stand for (:mod:`.room`): laid on that speech alone.
            al = again(clip, stand_in, cut) or al
    check_transcript_matches(al, judge_fit=english)
    refine_alignment(snd, al, model_for([p.source for p in prons]))
    _show(al, prons, phones)
    skipped = skipped_words(text, lexicon.language)
    if skipped:
        n = len(skipped)
        warning = (f"{n} word{'s' if n > 1 else ''} of the transcript left out, the aligner cannot use "
                   f"{'them' if n > 1 else 'it'}: {describe_skipped(skipped)}")
        al.notes.insert(0, warning)
        al.warnings.insert(0, warning)
    return al


#: Pronunciations the user wrote out (inline, in IPA) are said as written: no other is offered.
AS_WRITTEN = ("inline", "ipa")


def always_said(prons: list[Pronunciation], language: str) -> list[Pronunciation]:
    """The pronunciations as ``language`` always says them in running speech
    (:func:`..language.assimilation.said`: German "Lappen" [lapm̩]), their
    stand-ins for the aligner and the phones the mouth shows alike; those
    the user wrote out are kept as written."""
    phones = [p.aligned or p.phones for p in prons]
    out = list(prons)
    for k, (a, s) in enumerate(assimilation.said(phones, language, [p.phones for p in prons])):
        if a != phones[k] and prons[k].source not in AS_WRITTEN:
            out[k] = replace(prons[k], phones=s, aligned=a if prons[k].aligned else None)
    return out


def said_as(prons: list[Pronunciation], language: str) -> list[list[str]]:
    """The phones the aligner is given for each word (its stand-ins for a
    word read from IPA), with the other pronunciations running speech gives
    it (:func:`..language.assimilation.variants`), which the aligner chooses
    between by the sound."""
    phones = [p.aligned or p.phones for p in prons]
    found = assimilation.variants(phones, language, [p.phones for p in prons])
    return [Variants(ph, [a for a, _ in v], [s for _, s in v]) if v and p.source not in AS_WRITTEN else ph
            for ph, p, v in zip(phones, prons, found)]


def _show(al: Alignment, prons: list[Pronunciation], phones: list[list[str]]) -> None:
    """Words aligned by stand-in phones (:attr:`.Pronunciation.aligned`)
    get back the phones their mouth shows (those of the pronunciation the
    aligner chose among ``phones``' variants, :func:`said_as`)."""
    by_word: dict[int, list] = {}
    for p in al.phones:
        by_word.setdefault(p.word_index, []).append(p)
    where = [wi for wi, w in enumerate(al.words) if not w.recognized]      # the transcript's words among all
    for k, pron in enumerate(prons):
        if not pron.aligned:
            continue
        wi = where[k]
        got = by_word.get(wi, [])
        aligned, shown = pron.aligned, pron.phones
        for a, s in zip(getattr(phones[k], "variants", []), getattr(phones[k], "shown", [])):
            if [p.phone for p in got] == a:
                aligned, shown = a, s
        al.words[wi].phones = list(shown) if al.words[wi].spoken else []
        if [p.phone for p in got] == aligned:
            for p, s in zip(got, shown):
                p.phone = s
        else:   # the aligner changed the word's phones (a stretch placed by estimate): undo each stand-in alone
            back = {a: s for a, s in zip(pron.aligned, pron.phones) if a != s}
            for p in got:
                p.phone = back.get(p.phone, p.phone)


def align_file(path: str | os.PathLike, text: str, **kw) -> Alignment:
    """:func:`align_audio` on an audio file."""
    return align_audio(audio_mod.load(path), text, **kw)
