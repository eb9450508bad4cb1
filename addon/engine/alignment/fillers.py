"""Hesitations ("uh", "er") may be any voice sound.

A transcript writes a hesitation as a word, but the speaker may produce it as
a grunt, a breath or a hoarse murmur that fits none of its phones.  Forced to
use the word's phones, the aligner then puts the hesitation (and the words
around it) wherever the audio resembles a vowel, sometimes seconds away.
So a clip whose transcript holds a hesitation may have its word pass made
twice: as written, and with a second pronunciation of each hesitation in the
decoder's dictionary, the acoustic model's "speech-like noise" filler
(``+SPN+``).  The second is made only when the first leaves speech off its
words, and kept only if its words lie on clearly more of the speech
(:func:`prefer`).  The phone pass follows the one kept; if the decoder
chose the filler, :func:`restore` gives the word back its own phones,
spread over the time the filler took.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

import numpy as np

from .estimate import _estimate
from .model import Variants, word_frames

#: The acoustic model's filler phone for speech sounds that are not words.
FILLER = "+SPN+"

#: Hesitations that are a bare vowel ("uh", "er", "ah", "eh").  Those with a
#: hum ("um", "hmm") keep their own phones only: the closed lips of their
#: /m/ are seen, and the model finds the hum well.
_HESITATION = re.compile(r"^(u+h+|e+r+|a+h+|e+h+)$")


class Hesitation(list):
    """A hesitation's phones: the decoder also accepts :data:`FILLER` for it."""


def is_hesitation(text: str) -> bool:
    return bool(_HESITATION.match(text.lower()))


def mark(prons: Sequence[Sequence[str]], texts: Sequence[str]) -> list[list[str]]:
    """The phones of every word, those of hesitations as :class:`Hesitation`
    (a word's other pronunciations, :class:`.model.Variants`, are kept)."""
    return [Hesitation(p) if is_hesitation(t) else p if isinstance(p, Variants) else list(p)
            for p, t in zip(prons, texts)]


def dictionary_lines(token: str, phones: Sequence[str], fillers: bool = False) -> list[str]:
    """The decoder's dictionary entries of one word: its phones, its other
    pronunciations (:class:`.model.Variants`), and with ``fillers`` a
    hesitation's filler pronunciation too."""
    lines = [f"{token} {' '.join(phones)}"]
    others = ([[FILLER]] if fillers and isinstance(phones, Hesitation) else []) + getattr(phones, "variants", [])
    lines += [f"{token}({k}) {' '.join(v)}" for k, v in enumerate(others, 2)]
    return lines


def has_hesitation(prons: Sequence[Sequence[str]]) -> bool:
    return any(isinstance(p, Hesitation) for p in prons)


def uncovered(kind: str, payload, mask: np.ndarray) -> int:
    """Frames of speech (``mask``) that no decoded word lies on."""
    covered = np.zeros(len(mask), bool)
    for a, b in word_frames(kind, payload):
        covered[a:b] = True
    return int((mask & ~covered).sum())


def prefer(plain, with_fillers, mask: np.ndarray, margin: int):
    """Of two decodes of the same words (results of ``_decode`` or of the
    word pass alone, ``_word_pass``), the one with
    fillers only if it leaves at least ``margin`` fewer frames of speech
    off the words: the filler is a catch-all sound, and where the words
    themselves fit the speech as well, it only lets a hesitation wander
    onto the edge of a neighbouring word."""
    if with_fillers[0] == "failed":
        return plain
    if plain[0] == "failed":
        return with_fillers
    if uncovered(*with_fillers[::2], mask) + margin <= uncovered(*plain[::2], mask):
        return with_fillers
    return plain


def base_token(name: str) -> str:
    """A decoded word's token without its pronunciation variant: "w3(2)" -> "w3"."""
    return name.split("(", 1)[0]


def restore(result: list, prons: Sequence[Sequence[str]]) -> None:
    """In place: a word decoded as the filler gets its own phones back,
    spread over the filler's time by their typical durations."""
    for wi, ph in enumerate(result):
        if ph and any(p == FILLER for p, _, _ in ph):
            result[wi] = _estimate([list(prons[wi])], [(ph[0][1], ph[-1][2])])[0]
