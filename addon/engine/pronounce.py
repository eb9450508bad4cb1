"""Pronunciations: the CMU dictionary, a user dictionary, inline overrides and
letter-to-sound rules, in that order of trust (inline first).

A word is never dropped: if the dictionaries do not know it, it is split into
a known stem and an ending (``beauty's``, ``tatter'd``, ``feel'st``,
``thriftless``), or into two dictionary words (``spaceship``), and only then
spelled by :mod:`.lts` rules.  The result says where each pronunciation came
from, so a user can see which words were guessed.
"""

from __future__ import annotations

import os
import threading
from dataclasses import dataclass, field
from pathlib import Path

from . import lts
from .errors import TranscriptError
from .phonemes import PHONEMES, strip_stress
from .text import Word

_LOCK = threading.Lock()
_CMU: "_LazyDictionary | None" = None


def cmudict_path() -> Path:
    """The CMU dictionary shipped inside the pocketsphinx wheel."""
    import pocketsphinx

    return Path(pocketsphinx.get_model_path()) / "en-us" / "cmudict-en-us.dict"


def load_dictionary(path: str | os.PathLike) -> dict[str, list[list[str]]]:
    """Read a dictionary in CMU format: ``WORD PH ONES`` per line, alternates
    written ``word(2)``, ``;;;`` comments.  Stress digits are removed."""
    entries: dict[str, list[list[str]]] = {}
    with open(path, encoding="utf-8", errors="replace") as fh:
        for lineno, line in enumerate(fh, 1):
            line = line.split("#", 1)[0].strip() if not line.startswith(";;;") else ""
            if not line:
                continue
            parts = line.split()
            word = parts[0].lower()
            if word.endswith(")") and "(" in word:
                word = word[:word.index("(")]
            phones = [strip_stress(p.upper()) for p in parts[1:]]
            bad = [p for p in phones if p not in PHONEMES]
            if not phones or bad:
                raise TranscriptError(
                    f"{path}, line {lineno}: {'no phones' if not phones else 'unknown phones ' + ' '.join(bad)} "
                    f"for {parts[0]!r}; write ARPAbet, e.g. 'quokka K W AA1 K AH0'")
            entries.setdefault(word, []).append(phones)
    return entries


class _LazyDictionary:
    """The CMU dictionary, split into lines at load time and parsed per word
    on first use: reading 135,000 entries fully costs a second, this 60 ms."""

    def __init__(self, path: Path):
        self._raw: dict[str, str] = {}
        with open(path, encoding="utf-8", errors="replace") as fh:
            for line in fh.read().splitlines():
                word, _, phones = line.partition(" ")
                # Alternates "word(2)" follow the main entry; the first wins.
                if "(" not in word:
                    self._raw.setdefault(word, phones)
        self._parsed: dict[str, list[list[str]]] = {}

    def get(self, word: str) -> list[list[str]] | None:
        hit = self._parsed.get(word)
        if hit is None and word in self._raw:
            hit = [[strip_stress(p) for p in self._raw[word].split()]]
            self._parsed[word] = hit
        return hit

    def __contains__(self, word: str) -> bool:
        return word in self._raw


def cmudict() -> _LazyDictionary:
    global _CMU
    with _LOCK:
        if _CMU is None:
            _CMU = _LazyDictionary(cmudict_path())
        return _CMU


@dataclass
class Pronunciation:
    word: str
    phones: list[str]
    source: str  # "inline", "user", "cmudict", "derived", "rules"


@dataclass
class Lexicon:
    """Looks words up: user entries shadow the CMU dictionary."""

    user: dict[str, list[list[str]]] = field(default_factory=dict)

    @classmethod
    def with_user_file(cls, path: str | os.PathLike | None) -> "Lexicon":
        if not path:
            return cls()
        if not Path(path).is_file():
            raise TranscriptError(f"user dictionary not found: {path}")
        return cls(load_dictionary(path))

    def known(self, word: str) -> list[str] | None:
        hit = self.user.get(word) or cmudict().get(word)
        return list(hit[0]) if hit else None

    def pronounce(self, word: Word) -> Pronunciation:
        if word.phones is not None:
            phones = [strip_stress(p) for p in word.phones]
            bad = [p for p in phones if p not in PHONEMES]
            if bad:
                raise TranscriptError(
                    f"unknown phone(s) {' '.join(bad)} in the pronunciation {word.source!r}; use ARPAbet")
            return Pronunciation(word.text, phones, "inline")
        text = word.text
        if text in self.user:
            return Pronunciation(text, list(self.user[text][0]), "user")
        hit = self.known(text)
        if hit:
            return Pronunciation(text, hit, "cmudict")
        derived = self._derive(text)
        if derived:
            return Pronunciation(text, derived, "derived")
        spelled = _dedupe(lts.spell(text))
        if not spelled:
            raise TranscriptError(f"cannot pronounce {word.source!r}")
        return Pronunciation(text, spelled, "rules")

    # -- morphology -------------------------------------------------------
    def _derive(self, word: str) -> list[str] | None:
        bare = word.strip("'")
        if bare != word:
            hit = self.known(bare)
            if hit:
                return hit
        # Elided endings of verse and dialect: tatter'd, feel'st, o'er, 'tis.
        for ending in ("'d", "'st", "'s", "'ll", "'re", "'ve", "in'", "s'", "'n"):
            if bare.endswith(ending):
                stem = bare[: -len(ending)]
                if ending == "in'":
                    stem = bare[:-1] + "g"
                    hit = self.known(stem) or self._derive(stem)
                    return hit
                hit = self.known(stem) or (self._derive(stem) if len(stem) > 2 else None)
                if hit:
                    return hit + _ending_phones(ending, hit)
        bare = bare.replace("'", "")
        if bare != word and self.known(bare):
            return self.known(bare)
        for suffix, phones in _SUFFIXES:
            if bare.endswith(suffix) and len(bare) - len(suffix) >= 3:
                stem = bare[: -len(suffix)]
                for candidate in (stem, stem + "e", stem[:-1] if stem[-1:] == stem[-2:-1] else None,
                                  stem[:-1] + "y" if stem.endswith("i") else None):
                    if candidate and self.known(candidate):
                        base = self.known(candidate)
                        return base + (phones(base) if callable(phones) else phones.split())
        # Compounds of two dictionary words, longest first part first.
        for cut in range(len(bare) - 3, 2, -1):
            head, tail = self.known(bare[:cut]), self.known(bare[cut:])
            if head and tail and len(bare[:cut]) >= 3:
                return head + tail
        return None


_VOICELESS = {"P", "T", "K", "F", "TH"}
_SIBILANT = {"S", "Z", "SH", "ZH", "CH", "JH"}


def _plural(base: list[str]) -> list[str]:
    if base[-1] in _SIBILANT:
        return ["IH", "Z"]
    return ["S"] if base[-1] in _VOICELESS else ["Z"]


def _past(base: list[str]) -> list[str]:
    if base[-1] in {"T", "D"}:
        return ["IH", "D"]
    return ["T"] if base[-1] in _VOICELESS | {"S", "SH", "CH"} else ["D"]


def _ending_phones(ending: str, base: list[str]) -> list[str]:
    return {"'d": _past(base), "'st": ["S", "T"] if base[-1] not in _SIBILANT else ["IH", "S", "T"],
            "'s": _plural(base), "s'": [], "'ll": ["L"], "'re": ["ER"], "'ve": ["V"],
            "'n": ["AH", "N"]}[ending]


_SUFFIXES = (
    ("lessness", "L AH S N AH S"), ("fulness", "F AH L N AH S"), ("ness", "N AH S"),
    ("less", "L AH S"), ("ful", "F AH L"), ("ly", "L IY"), ("ment", "M AH N T"),
    ("ings", "IH NG Z"), ("ing", "IH NG"), ("ers", "ER Z"), ("er", "ER"), ("est", "AH S T"),
    ("ed", _past), ("es", _plural), ("s", _plural), ("able", "AH B AH L"), ("ish", "IH SH"),
    ("y", "IY"),
)


def _dedupe(phones: list[str]) -> list[str]:
    out: list[str] = []
    for p in phones:
        if not out or p != out[-1] or p in {"AH", "IH"}:
            out.append(p)
    return out
