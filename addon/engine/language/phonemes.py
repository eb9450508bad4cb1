"""The ARPAbet phoneme inventory and conversions from IPA and SAMPA.

IPA of any language is read by articulatory features (:mod:`.ipa`).

Everything inside the engine speaks ARPAbet without stress digits (``AH``, not
``AH0``), plus ``SIL`` for silence.  Labels written by other tools (Montreal
Forced Aligner, praat TextGrids, Papagayo, Rhubarb) are converted here, and a
label that cannot be converted raises :class:`UnknownLabelError` naming it.
"""

from __future__ import annotations

import re

from . import ipa
from ..errors import UnknownLabelError

SILENCE = "SIL"

VOWELS = frozenset(
    "AA AE AH AO AW AY EH ER EY IH IY OW OY UH UW".split()
)
DIPHTHONGS = frozenset("AW AY EY OW OY".split())

#: Place/manner class of every consonant.  The classes drive the weight
#: equations (plosive and fricative use pitch only) and the coarticulation
#: parameters (bilabials and labiodentals must reach their target).
CONSONANT_CLASS = {
    "P": "bilabial", "B": "bilabial", "M": "bilabial",
    "F": "labiodental", "V": "labiodental",
    "TH": "dental", "DH": "dental",
    "T": "alveolar", "D": "alveolar", "N": "alveolar", "S": "alveolar", "Z": "alveolar",
    "SH": "postalveolar", "ZH": "postalveolar", "CH": "postalveolar", "JH": "postalveolar",
    "K": "velar", "G": "velar", "NG": "velar", "HH": "velar",
    "L": "liquid", "R": "liquid",
    "W": "glide", "Y": "glide",
}

#: Manner of articulation, used by equations 1 and 2 of the first paper.
MANNER = {
    **{p: "plosive" for p in "P B T D K G".split()},
    **{p: "fricative" for p in "F V TH DH S Z SH ZH HH".split()},
    **{p: "affricate" for p in "CH JH".split()},
    **{p: "nasal" for p in "M N NG".split()},
    **{p: "liquid" for p in "L R".split()},
    **{p: "glide" for p in "W Y".split()},
    **{p: "vowel" for p in VOWELS},
    SILENCE: "silence",
}

PHONEMES = frozenset(MANNER) - {SILENCE}
ALL_LABELS = frozenset(MANNER)

#: Classes a preset can tune, in a fixed order.
CLASSES = (
    "vowel", "bilabial", "labiodental", "dental", "alveolar", "postalveolar",
    "velar", "liquid", "glide", "silence",
)


def phone_class(phone: str) -> str:
    """Return the articulation class (one of :data:`CLASSES`) of an ARPAbet phone."""
    if phone == SILENCE:
        return "silence"
    if phone in VOWELS:
        return "vowel"
    return CONSONANT_CLASS[phone]


def is_vowel(phone: str) -> bool:
    return phone in VOWELS


_STRESS = re.compile(r"^([A-Z]+)[0-2]$")
_SILENCE_LABELS = {"", "SIL", "SP", "SPN", "<SIL>", "<SP>", "SILENCE", "PAU", "#", "_", "REST", "X", "<UNK>"}


def strip_stress(label: str) -> str:
    m = _STRESS.match(label)
    return m.group(1) if m else label


def split_arpabet(label: str) -> list[str] | None:
    """Split a label made of several ARPAbet phones run together (``PT``).

    Hand labellers sometimes merge two phones into one interval; the split
    is greedy, longest phone first, and ``None`` means the label is not such a
    run.
    """
    out: list[str] = []
    rest = label
    while rest:
        for n in (2, 1):
            head = rest[:n]
            if head in PHONEMES:
                out.append(head)
                rest = rest[n:]
                break
        else:
            return None
    # Two different phones at most: "PT" is a merge, "ZZZ" is a typo.
    return out if len(out) == 2 and out[0] != out[1] else None


# X-SAMPA / SAMPA (English) -> ARPAbet.
SAMPA = {
    "A": "AA", "A:": "AA", "Q": "AA", "{": "AE", "V": "AH", "@": "AH", "6": "AH",
    "O": "AO", "O:": "AO", "aU": "AW", "aI": "AY", "E": "EH", "e": "EH", "3`": "ER",
    "@`": "ER", "3": "ER", "3:": "ER", "eI": "EY", "I": "IH", "i": "IY", "i:": "IY",
    "@U": "OW", "oU": "OW", "o": "OW", "OI": "OY", "U": "UH", "u": "UW", "u:": "UW",
    "b": "B", "tS": "CH", "d": "D", "D": "DH", "4": "D", "f": "F", "g": "G",
    "h": "HH", "dZ": "JH", "k": "K", "l": "L", "5": "L", "m": "M", "n": "N",
    "N": "NG", "p": "P", "r": "R", "r\\": "R", "s": "S", "S": "SH", "t": "T",
    "T": "TH", "v": "V", "w": "W", "j": "Y", "z": "Z", "Z": "ZH", "?": "T",
}


def _greedy(label: str, table: dict[str, str]) -> list[str] | None:
    out: list[str] = []
    i = 0
    longest = max(len(k) for k in table)
    while i < len(label):
        for n in range(min(longest, len(label) - i), 0, -1):
            piece = label[i:i + n]
            if piece in table:
                out.append(table[piece])
                i += n
                break
        else:
            return None
    return out


def to_arpabet(label: str, phoneset: str = "auto") -> list[str]:
    """Convert one interval label to a list of ARPAbet phones.

    ``phoneset`` is ``"arpabet"``, ``"ipa"``, ``"sampa"`` or ``"auto"`` (try
    ARPAbet, then SAMPA, then IPA).  Silence labels give ``["SIL"]``.  A label
    that no table explains raises :class:`UnknownLabelError`.
    """
    raw = label.strip()
    # Lower-case "x" is the IPA velar fricative; upper-case "X" is Rhubarb's rest.
    if raw.upper() in _SILENCE_LABELS and raw != "x":
        return [SILENCE]
    tries = {"arpabet": ("arpabet",), "ipa": ("ipa",), "sampa": ("sampa",),
             "auto": ("arpabet", "sampa", "ipa")}.get(phoneset)
    if tries is None:
        raise ValueError(f"unknown phone set {phoneset!r}: use arpabet, ipa, sampa or auto")
    for kind in tries:
        if kind == "arpabet":
            up = strip_stress(raw.upper()) if raw.isupper() or phoneset == "arpabet" else None
            if up in PHONEMES:
                return [up]
            if up is not None:
                run = split_arpabet(up)
                if run:
                    return run
        elif kind == "sampa":
            if raw in SAMPA:
                return [SAMPA[raw]]
            if phoneset == "sampa":
                got = _greedy(raw, SAMPA)
                if got:
                    return got
        else:
            try:
                return ipa.to_arpabet(raw)
            except ipa.UnknownSymbol as exc:
                raise UnknownLabelError(label, phoneset, symbol=exc.symbol) from None
    raise UnknownLabelError(label, phoneset)
