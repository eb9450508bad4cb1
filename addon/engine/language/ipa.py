"""IPA labels of any language -> the engine's phones, by articulatory features.

Forced aligners trained on many languages (Montreal Forced Aligner's
pretrained models among them) label phones in IPA: German ``ʁ ç øː``, French
nasal vowels, Spanish ``ɾ β ð ɣ``, Japanese ``ɯ ɕ ɴ``, Mandarin with tone
letters, Russian palatalised consonants.  Each base symbol has its features
in ``data/ipa.json`` (consonants: place, manner, voicing; vowels: height,
backness, rounding), and the same file says which ARPAbet phone shows the
same mouth for those features: what the lips and jaw do is decided by place,
rounding and openness, not by a list of English look-alikes.

A label is read symbol by symbol (after Unicode decomposition, so ``ã`` is
``a`` plus a nasal tilde):

* base symbols start a segment; two in a row that form an affricate
  (``tʃ``, ``t͡ɕ``, ``ʈʂ``) give one phone, and a vowel followed by a closer
  vowel or glide that makes an English diphthong (``aɪ``, ``aj``, ``oʊ``) gives
  that diphthong; any other sequence gives one phone per segment (the
  interval is shared), and a doubled symbol (a geminate written ``tt``) is one
  phone;
* a whole word written in IPA (``word=True``, a transcript's ``/.../``) is read
  as phoneticians segment it: every base symbol is a phone of its own, two
  symbols are one affricate or diphthong only when tied (``t͡ʃ``, ``a͡ɪ``) or
  written as one ligature (``ʧ``), and a doubled symbol stays two phones
  (``ɔɔ`` is two vowels, often on two tones).  Each written segment then gets
  its own start: on VoxAngeles (``bench/languages.py``) the segments merged
  by the label rules above (``aj``, ``tʃ``, ``ee``) were 2.5 % of the phones,
  each a start missed, and aligning the segments apart placed their
  neighbours better too;
* diacritics and modifier letters (length ``ː``, stress ``ˈ ˌ``, nasal ``̃``,
  palatalisation ``ʲ``, aspiration ``ʰ``, devoicing, syllabicity, ties, tone
  letters ``˥˦˧˨˩`` and tone or stress digits) change nothing the mouth shows,
  except the r-colour hook ``˞``, which makes a vowel ER, and, in a written
  word, labialisation ``ʷ``: the lips round through the consonant's release,
  a W of its own after it (``kʷ`` is K W; of VoxAngeles' nine languages that
  write it, phone starts within 20 ms rose in eight and held in the ninth,
  44.0 % to 47.2 % on Columbia-Wenatchi, and no phone of another language
  moved);
* anything else is not IPA and raises :class:`UnknownSymbol`, naming it.
"""

from __future__ import annotations

import json
import unicodedata
from functools import lru_cache
from pathlib import Path

DATA = Path(__file__).parent.parent / "data" / "ipa.json"

#: Modifier letters and marks that carry no visible articulation.
#: Tie bars: two symbols written as one segment.
TIES = frozenset("͜͡")

#: Labialisation: in a word written in IPA, the lips round through the consonant's release.
LABIALISED = "ʷ"

MODIFIERS = set("ˈˌːˑ.‿͜͡ʰʱʲʷˠˤⁿˡʼ̚ᵊ˞-_|‖↗↘ꜛꜜ") | set("˥˦˧˨˩꜒꜓꜔꜕꜖꜀꜁꜂꜃꜄꜅꜆꜇꜈꜉꜊꜋꜌꜍꜎꜏꜐꜑") | set("0123456789")


class UnknownSymbol(ValueError):
    """A character of a label that is neither an IPA symbol nor a mark."""

    def __init__(self, symbol: str, label: str):
        self.symbol = symbol
        self.label = label
        super().__init__(f"{symbol!r} (U+{ord(symbol):04X}) in {label!r} is not an IPA symbol")


@lru_cache(maxsize=1)
def table() -> dict:
    with open(DATA, encoding="utf-8") as fh:
        return json.load(fh)


def consonant_phone(place: str, manner: str, voiced: bool) -> str:
    by_manner = table()["consonant_phone"][place]
    pair = by_manner.get(manner) or by_manner["*"]
    return pair[1 if voiced else 0]


def vowel_phone(height: int, backness: str, rounded: bool, rhotic: bool = False) -> str:
    if rhotic and height >= 2:
        return "ER"
    rows = table()["vowel_phone"]["rounded" if rounded else "unrounded"]
    return rows[max(0, min(6, int(height)))][("front", "central", "back").index(backness)]


def _is_mark(ch: str) -> bool:
    return ch in MODIFIERS or unicodedata.category(ch) == "Mn"


def _symbols(label: str) -> list[tuple[str, set[str]]]:
    """Base symbols of ``label`` with the marks that follow each."""
    tab = table()
    known = tab["consonants"].keys() | tab["vowels"].keys()
    lig = tab["ligatures"]
    out: list[tuple[str, set[str]]] = []
    pending = list(unicodedata.normalize("NFC", label.strip()))
    while pending:
        ch = pending.pop(0)
        if ch in lig:
            pending[:0] = list(lig[ch])
        elif ch in known:
            out.append((ch, set()))
        elif _is_mark(ch):
            if out:
                out[-1][1].add(ch)
        else:
            parts = unicodedata.normalize("NFD", ch)
            if parts != ch and parts[0] in known:
                pending[:0] = list(parts)
            else:
                raise UnknownSymbol(ch, label)
    return out


def to_arpabet(label: str, word: bool = False) -> list[str]:
    """ARPAbet phones for one IPA label, or with ``word`` for a whole word
    written in IPA (see the module docstring)."""
    tab = table()
    syms = _symbols(label)
    if not syms:
        raise UnknownSymbol(label.strip()[:1] or " ", label)
    phones: list[str] = []
    kinds: list[str] = []
    tied: list[bool] = []
    k = 0
    while k < len(syms):
        ch, marks = syms[k]
        joins = not word or bool(marks & TIES)
        if joins and k + 1 < len(syms) and ch + syms[k + 1][0] in tab["affricates"]:
            phones.append(tab["affricates"][ch + syms[k + 1][0]])
            kinds.append("C")
            tied.append(False)
            k += 2
            continue
        rounds = False
        if ch in tab["vowels"]:
            height, back, rounded = tab["vowels"][ch][:3]
            phones.append(vowel_phone(height, back, rounded, "˞" in marks))
            kinds.append("V")
        else:
            phones.append(consonant_phone(*tab["consonants"][ch]))
            kinds.append("C")
            rounds = word and LABIALISED in marks and phones[-1] != "W"
        tied.append(joins)
        if rounds:      # the lips round through the consonant's release: a W of its own after it
            phones.append("W")
            kinds.append("C")
            tied.append(joins)
        k += 1
    # Geminates and doubled vowels: one phone (a written word keeps both).
    merged: list[str] = []
    mk: list[str] = []
    mt: list[bool] = []
    for p, kind, t in zip(phones, kinds, tied):
        if merged and merged[-1] == p and not word:
            continue
        merged.append(p)
        mk.append(kind)
        mt.append(t)
    # A vowel and a closer vowel or glide after it: a diphthong when one fits
    # (in a written word, when the two are tied).
    out: list[str] = []
    k = 0
    while k < len(merged):
        if k + 1 < len(merged) and mk[k] == "V" and mt[k]:
            d = tab["diphthongs"].get(f"{merged[k]} {merged[k + 1]}")
            if d:
                out.append(d)
                k += 2
                continue
        out.append(merged[k])
        k += 1
    return out
