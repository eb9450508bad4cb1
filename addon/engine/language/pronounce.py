"""Pronunciations: the CMU dictionary, a user dictionary, inline overrides and
letter-to-sound rules, in that order of trust (inline first); a word written
in IPA (``/pɛs/``) by its IPA; a word of another language than English by
eSpeak NG (:mod:`.espeak`), after inline overrides and the user dictionary.

A word is never dropped: if the dictionaries do not know it, it is split into
a known stem and an ending (``beauty's``, ``tatter'd``, ``feel'st``,
``thriftless``), or into two dictionary words (``spaceship``), and only then
spelled by :mod:`.lts` rules.  The result says where each pronunciation came
from, so a user can see which words were guessed.
"""

from __future__ import annotations

import bisect
import os
import threading
from dataclasses import dataclass, field
from pathlib import Path

from . import lts
from .languages import Language, resolve, stand_ins
from ..errors import TranscriptError
from .phonemes import PHONEMES, strip_stress
from .text import Word

_LOCK = threading.Lock()
_CMU: _SortedDictionary | None = None
_SPOKEN: dict[tuple[str, str], list[str]] = {}   # (eSpeak voice, word) -> phones


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


class _SortedDictionary:
    """The CMU dictionary, looked up in place: the file is sorted by word
    (alternates ``word(2)`` follow their main entry), so a word is found by
    bisecting its lines.  Opening it costs a few milliseconds instead of the
    ~0.3 s of splitting 135,000 entries into a table; a file that is not
    sorted is read into a table instead."""

    def __init__(self, path: Path):
        import numpy as np

        with open(path, "rb") as fh:
            self._data = fh.read()
        ends = np.flatnonzero(np.frombuffer(self._data, np.uint8) == 10)
        self._starts = np.concatenate([[0], ends + 1])[:-1 if len(self._data) and self._data.endswith(b"\n") else None]
        self._table: dict[bytes, bytes] | None = None
        self._parsed: dict[str, list[list[str]] | None] = {}
        probe = [self._word(i) for i in np.linspace(0, len(self._starts) - 1, 65).astype(int)]
        if probe != sorted(probe):
            self._table = {}
            for i in range(len(self._starts)):
                line = self._line(i)
                word, _, phones = line.partition(b" ")
                if b"(" not in word:
                    self._table.setdefault(word, phones)

    def _line(self, i: int) -> bytes:
        a = int(self._starts[i])
        b = self._data.find(b"\n", a)
        return self._data[a:b if b >= 0 else len(self._data)].rstrip(b"\r")

    def _word(self, i: int) -> bytes:
        """The line's word without an alternate's "(2)"."""
        return self._line(i).partition(b" ")[0].partition(b"(")[0]

    def _find(self, word: bytes) -> bytes | None:
        if self._table is not None:
            return self._table.get(word)
        i = bisect.bisect_left(range(len(self._starts)), word, key=self._word)
        while i < len(self._starts) and self._word(i) == word:
            head, _, phones = self._line(i).partition(b" ")
            if b"(" not in head:
                return phones
            i += 1
        return None

    def get(self, word: str) -> list[list[str]] | None:
        if word not in self._parsed:
            try:
                raw = self._find(word.encode("utf-8"))
            except UnicodeEncodeError:
                raw = None
            self._parsed[word] = [[strip_stress(p) for p in raw.decode("utf-8", "replace").split()]] if raw else None
        return self._parsed[word]

    def __contains__(self, word: str) -> bool:
        return self.get(word) is not None


def cmudict() -> _SortedDictionary:
    global _CMU
    with _LOCK:
        if _CMU is None:
            _CMU = _SortedDictionary(cmudict_path())
        return _CMU


@dataclass
class Pronunciation:
    word: str
    phones: list[str]
    source: str  # "inline", "ipa", "user", "cmudict", "derived", "rules", "espeak"
    #: The phones the English acoustic model is asked to find, one for each of ``phones``, when they
    #: differ (a word read from IPA: :func:`.languages.stand_ins`).
    aligned: list[str] | None = None

    def __post_init__(self):
        if self.source in ("ipa", "espeak") and self.aligned is None:
            subs = stand_ins()
            aligned = [subs.get(p, p) for p in self.phones]
            self.aligned = aligned if aligned != self.phones else None


@dataclass
class Lexicon:
    """Looks words up: user entries shadow the CMU dictionary (English) or
    eSpeak NG (any other ``language``)."""

    user: dict[str, list[list[str]]] = field(default_factory=dict)
    language: Language = field(default_factory=resolve)

    @classmethod
    def with_user_file(cls, path: str | os.PathLike | None, language: str | Language | None = None) -> Lexicon:
        lang = resolve(language)
        if not path:
            return cls(language=lang)
        if not Path(path).is_file():
            raise TranscriptError(f"user dictionary not found: {path}")
        return cls(load_dictionary(path), lang)

    def known(self, word: str) -> list[str] | None:
        hit = self.user.get(word) or cmudict().get(word)
        return list(hit[0]) if hit else None

    def pronounce(self, word: Word) -> Pronunciation:
        if word.ipa is not None:
            return Pronunciation(word.text, list(word.phones), "ipa")
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
        if not self.language.is_english:
            return Pronunciation(text, self._espeak(word), "espeak")
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

    def _espeak(self, word: Word) -> list[str]:
        from . import espeak

        lang = self.language
        key = (lang.espeak, word.source)
        if key not in _SPOKEN:
            written = word.source
            if lang.code == "ja":
                from . import japanese

                written = japanese.reading(written)
            _SPOKEN[key] = espeak.pronounce(written, lang.espeak, lang.phone_fixes)
        return list(_SPOKEN[key])

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
