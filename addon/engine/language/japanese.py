"""Japanese: words and readings with pykakasi.

Japanese is written without spaces, in kanji and kana; eSpeak NG reads kana
only.  pykakasi (GPL-3.0-or-later, pure Python, its dictionary in its wheel)
cuts a run of Japanese into words and gives each its reading in hiragana,
which eSpeak NG then speaks (:mod:`.espeak`).  Without pykakasi, a run of
kana is one word and a word in kanji is an error asking for its reading.
"""

from __future__ import annotations

import re
import threading

from ..errors import TranscriptError

#: Han characters (kanji).
KANJI = re.compile(r"[\u3400-\u4dbf\u4e00-\u9fff\uf900-\ufaff\u3005]")
#: Kana, kanji and the prolonged-sound mark: what pykakasi cuts into words.
JAPANESE = re.compile(r"[\u3040-\u30ff\u3400-\u4dbf\u4e00-\u9fff\uf900-\ufaff\u3005\u30fc]")

_LOCK = threading.Lock()
_KAKASI = None


def _kakasi():
    global _KAKASI
    with _LOCK:
        if _KAKASI is None:
            try:
                import pykakasi
            except ImportError:
                return None
            _KAKASI = pykakasi.kakasi()
        return _KAKASI


def available() -> bool:
    return _kakasi() is not None


def words(run: str) -> list[str]:
    """A run of Japanese cut into words (the run itself without pykakasi)."""
    k = _kakasi()
    if k is None or not JAPANESE.search(run):
        return [run]
    out = [seg["orig"] for seg in k.convert(run) if seg["orig"].strip()]
    return out or [run]


#: Particles written with the kana of another sound: topic は is "wa", direction へ is "e".
PARTICLES = {"は": "わ", "へ": "え"}


def reading(word: str) -> str:
    """The word in kana: as written when it has no kanji (a particle as it
    is said), else its hiragana reading from pykakasi."""
    if word in PARTICLES:
        return PARTICLES[word]
    if not KANJI.search(word):
        return word
    k = _kakasi()
    if k is None:
        raise TranscriptError(f"{word!r}: Japanese kanji need their reading, and pykakasi is not installed "
                              "(pip install pykakasi==2.3.0); or write the word in hiragana or katakana, or "
                              "its IPA between slashes")
    return "".join(seg["hira"] for seg in k.convert(word))
