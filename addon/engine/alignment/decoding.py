"""pocketsphinx decoding: a decoder knowing the clip's words (each a unique
token ``w<i>``), a forced or grammar word pass, then the phone pass, each
checked word by word against the transcript."""

from __future__ import annotations

import os
import re
import tempfile
import threading
from collections.abc import Sequence
from types import SimpleNamespace

import numpy as np

from ..audio import Audio
from .fillers import base_token, dictionary_lines, has_hesitation, prefer, uncovered
from .model import FRAME, AlignSettings


#: A kept decoder is set aside for a fresh one after this many words were added to it (each line
#: adds its own: the dictionary would otherwise grow with every line of a batch).
MOST_WORDS = 20000
#: A name in a grammar or an alignment text.
_NAME = re.compile(r"[^\s()\[\]|<>/;=*+]+")
#: The phones of the bundled acoustic model.  A dictionary file's entry with no phones, or with one
#: the model lacks, is passed over when pocketsphinx reads it; a word added with none crashes it, so
#: such an entry is passed over here too.
MODEL_PHONES = frozenset(("AA AE AH AO AW AY B CH D DH EH ER EY F G HH IH IY JH K L M N NG OW OY P R S SH "
                          "SIL T TH UH UW V W Y Z ZH +NSN+ +SPN+").split())


class _Kept:
    """A pocketsphinx decoder of each configuration, not in use, kept for
    the next :func:`_decoder` of this thread (loading the acoustic model
    takes 10 ms, a tenth of a short line's alignment)."""

    def __init__(self):
        self.free: dict[tuple, list] = {}
        self.uses = 0


_KEPT = threading.local()


class _Decoder:
    """A pocketsphinx decoder holding the words of one use, named as the
    caller names them (``w<i>``, ``x<phone>``): each word is added to a kept
    decoder's dictionary under a name of this use's own, and the names are
    mapped both ways in grammars, alignment texts, segments and alignments.
    The decoder goes back to the kept ones when this is dropped.  Results are
    those of a decoder made afresh: its features start afresh (noise removal
    learns from each utterance, and would carry one line's noise to the
    next), their normalisation is per utterance (``cmn`` batch), and no other
    use's word is in its searches."""

    def __init__(self, key: tuple, lines: list[str], extra: dict):
        import pocketsphinx

        kept = getattr(_KEPT, "kept", None) or _Kept()
        _KEPT.kept = kept
        free = kept.free.setdefault(key, [])
        kept.uses += 1
        self._key, self._kept = key, kept
        self._prefix = f"u{kept.uses}_"
        self._decoder, self._words = free.pop() if free else (None, 0)
        if self._decoder is not None:
            # Noise removal learns from each utterance and carries it to the next: start afresh.
            self._decoder.reinit_feat()
        else:
            beam, pbeam, wbeam, silprob = key[:4]
            with tempfile.NamedTemporaryFile("w", suffix=".dict", delete=False) as fh:
                path = fh.name
            try:
                self._decoder = pocketsphinx.Decoder(
                    lm=None, dict=path, bestpath=False, samprate=16000, loglevel="FATAL",
                    beam=beam, pbeam=pbeam, wbeam=wbeam, silprob=silprob, **extra)
            finally:
                os.unlink(path)
        entries = [line.split() for line in lines]
        entries = [e for e in entries if len(e) > 1 and MODEL_PHONES.issuperset(e[1:])]
        self._names = {e[0].split("(")[0] for e in entries}
        for k, e in enumerate(entries):
            self._decoder.add_word(self._prefix + e[0], " ".join(e[1:]), k == len(entries) - 1)
        self._words += len(entries)

    def __del__(self):
        kept = getattr(self, "_kept", None)
        free = kept.free.setdefault(self._key, []) if kept is not None else None
        if free is not None and not free and self._decoder is not None and self._words < MOST_WORDS:
            free.append((self._decoder, self._words))   # one a configuration: each holds the model (7 MB)

    def _in(self, text: str) -> str:
        return _NAME.sub(lambda m: self._prefix + m.group(0) if m.group(0) in self._names else m.group(0), text)

    def _out(self, name: str) -> str:
        return name[len(self._prefix):] if name.startswith(self._prefix) else name

    def set_align_text(self, text: str) -> None:
        self._decoder.set_align_text(self._in(text))

    def add_jsgf_string(self, name: str, grammar: str) -> None:
        self._decoder.add_jsgf_string(name, self._in(grammar))

    def seg(self):
        segs = self._decoder.seg()
        return None if segs is None else [SimpleNamespace(word=self._out(sg.word), start_frame=sg.start_frame,
                                                          end_frame=sg.end_frame) for sg in segs]

    def get_alignment(self):
        alignment = self._decoder.get_alignment()
        return None if alignment is None else [_Word(self._out(w.name), list(w)) for w in alignment]

    def __getattr__(self, attr: str):       # start_utt, process_raw, end_utt, activate_search, set_alignment
        if attr.startswith("_"):
            raise AttributeError(attr)
        return getattr(self._decoder, attr)


class _Word(list):
    """One word of an alignment: its phones, and its ``name``."""

    def __init__(self, name: str, phones: list):
        super().__init__(phones)
        self.name = name


def _decoder(prons: Sequence[Sequence[str]], first: int, settings: AlignSettings, fillers: bool = False,
             more: Sequence[str] = (), **extra):
    """A decoder that knows the given words, as tokens w<i> (with
    ``fillers``, a hesitation also as a filler: :mod:`.fillers`), and the
    dictionary lines ``more``, and no other words under those names; a
    kept one where there is one (:class:`_Decoder`)."""
    lines = [line for k, ph in enumerate(prons) for line in dictionary_lines(f"w{first + k}", ph, fillers)]
    key = (settings.beam, settings.pbeam, settings.wbeam, settings.silprob, tuple(sorted(extra.items())))
    return _Decoder(key, lines + list(more), extra)


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
    first = _word_pass(decoder, pcm, search, tokens, mode)
    if first[0] == "failed":
        return first
    return _finish(decoder, pcm, first, mode)


def _word_pass(decoder, pcm: bytes, search: str, tokens: list[str], mode: str):
    """The first pass alone: ("words", words used, word frames, tokens found)
    or ("failed", 0, reason).  The decoder keeps it for :func:`_finish`."""
    try:
        if mode == "all":
            decoder.set_align_text(" ".join(tokens))
        else:
            decoder.add_jsgf_string(search, _grammar(tokens, mode))
            decoder.activate_search(search)
        decoder.start_utt()
        decoder.process_raw(pcm, full_utt=True)
        decoder.end_utt()
        segs = [(base_token(sg.word), sg.start_frame, sg.end_frame) for sg in (decoder.seg() or [])]
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
    return ("words", len(got), [(sg[1], sg[2] + 1) for sg in found], got)


def _finish(decoder, pcm: bytes, first, mode: str):
    """The phone pass after the decoder's word pass ``first``; the word
    frames are kept if it fails."""
    _, used, word_frames, got = first
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
        return ("words", used, word_frames)
    return ("phones", used, phones)


def phone_alignment(decoder, pcm: bytes) -> list[tuple[str, list[tuple[str, int, int, int]]]]:
    """(word, [(phone, first frame, end frame, score)]) for every entry of
    the decoder's last hypothesis (words, silences, fillers), from a
    state-level alignment pass over ``pcm``.  A phone's score is its
    acoustic score summed over its frames, each frame's taken against the
    best senone of that frame (0 where the phone's own senones are the
    best; more negative the worse the phone fits the sound: see
    :attr:`.model.AlignedWord.fit`).  Raises RuntimeError when pocketsphinx
    finds none."""
    decoder.set_alignment()
    decoder.start_utt()
    decoder.process_raw(pcm, full_utt=True)
    decoder.end_utt()
    alignment = decoder.get_alignment()
    if alignment is None:
        raise RuntimeError("no sub-word alignment")
    return [(w.name, [(p.name, p.start, p.start + p.duration, p.score) for p in w]) for w in alignment]


def _phone_pass(decoder, pcm: bytes, got: list[str]):
    known = set(got)
    try:
        words = [(base_token(name), ph) for name, ph in phone_alignment(decoder, pcm) if base_token(name) in known]
    except RuntimeError:
        return None
    if [w[0] for w in words] != got:
        return None
    return [w[1] for w in words]


def _whole(audio: Audio, prons: list[list[str]], first: int, t0: float, t1: float, settings: AlignSettings,
           speech: np.ndarray | None = None):
    """Forced alignment of words ``first..`` to the audio t0..t1 in one pass.

    Given ``speech``, the clip's speech mask (:func:`.speech.speech_mask`,
    one value per frame from the clip's start), a hesitation may be a filler
    sound (:mod:`.fillers`): the word pass is made twice, as written and with
    fillers, and the phone pass follows the one :func:`.fillers.prefer`
    keeps.  The second word pass is skipped when the first leaves too little
    speech off its words for the fillers to be preferred."""
    tokens = [f"w{first + i}" for i in range(len(prons))]
    pcm = audio.pcm16(t0, t1)
    decoder = _decoder(prons, first, settings)
    plain = _word_pass(decoder, pcm, "all", tokens, "all")
    if speech is not None and has_hesitation(prons):
        margin = int(round(settings.filler_margin / FRAME))
        mask = speech[int(round(t0 / FRAME)):int(round(t1 / FRAME))]
        if plain[0] == "failed" or uncovered("words", plain[2], mask) >= margin:
            filler_decoder = _decoder(prons, first, settings, fillers=True)
            with_fillers = _word_pass(filler_decoder, pcm, "all", tokens, "all")
            if prefer(plain, with_fillers, mask, margin) is with_fillers:
                decoder, plain = filler_decoder, with_fillers
    if plain[0] == "failed":
        return plain
    return _finish(decoder, pcm, plain, "all")
