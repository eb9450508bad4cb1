"""Spelling to phones in other languages with eSpeak NG, offline.

eSpeak NG (GPL-3.0-or-later) reads a hundred languages: their spelling,
numbers (as words of the language) and abbreviations.  Its library and
data come in the ``espeakng-loader`` wheel, and are driven here through
ctypes: :func:`ipa_words` gives the IPA of each word eSpeak hears in a piece
of text, one list of phonemes per word, and :func:`to_phones` maps those
phonemes to the engine's own phones by their articulatory features
(:mod:`.ipa`).  :func:`synthesize` speaks text to samples (for tests and
benchmarks: a line whose words are known to be in it).

The library keeps one voice and one state per process, so every call holds
a lock.
"""

from __future__ import annotations

import ctypes
import re
import threading
import unicodedata

from . import ipa
from ..errors import LipSyncError, TranscriptError

_LOCK = threading.RLock()
_LIB = None
_RATE = 0
_VOICE: str | None = None

#: espeak_TextToPhonemes: text is UTF-8; phonemes in IPA, separated by this character.
_CHARS_UTF8 = 1
_PHONEMES_IPA = 0x02
_SEPARATOR = "_"
_AUDIO_SYNCHRONOUS = 2
_SWITCH = re.compile(r"\([a-z]{2,3}(?:-[a-z0-9]+)*\)")   # "(en)": eSpeak changed language for a word

_SYNTH_CALLBACK = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.POINTER(ctypes.c_short), ctypes.c_int, ctypes.c_void_p)


def available() -> bool:
    try:
        _library()
    except LipSyncError:
        return False
    return True


def _library():
    """The eSpeak NG library, loaded and initialised once per process."""
    global _LIB, _RATE
    with _LOCK:
        if _LIB is not None:
            return _LIB
        try:
            import espeakng_loader
        except ImportError:
            raise LipSyncError("languages other than English are read with eSpeak NG, which is not installed: "
                               "pip install espeakng-loader==0.2.4") from None
        try:
            lib = ctypes.CDLL(espeakng_loader.get_library_path())
            data = espeakng_loader.get_data_path()
        except (OSError, RuntimeError) as exc:
            raise LipSyncError(f"cannot load eSpeak NG from espeakng-loader: {exc}") from None
        lib.espeak_Initialize.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.c_char_p, ctypes.c_int]
        lib.espeak_Initialize.restype = ctypes.c_int
        lib.espeak_SetVoiceByName.argtypes = [ctypes.c_char_p]
        lib.espeak_SetVoiceByName.restype = ctypes.c_int
        lib.espeak_TextToPhonemes.argtypes = [ctypes.POINTER(ctypes.c_void_p), ctypes.c_int, ctypes.c_int]
        lib.espeak_TextToPhonemes.restype = ctypes.c_char_p
        lib.espeak_SetSynthCallback.argtypes = [_SYNTH_CALLBACK]
        lib.espeak_Synth.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_uint, ctypes.c_int, ctypes.c_uint,
                                     ctypes.c_uint, ctypes.c_void_p, ctypes.c_void_p]
        lib.espeak_Synth.restype = ctypes.c_int
        lib.espeak_Info.argtypes = [ctypes.POINTER(ctypes.c_char_p)]
        lib.espeak_Info.restype = ctypes.c_char_p
        rate = lib.espeak_Initialize(_AUDIO_SYNCHRONOUS, 0, data.encode("utf-8"), 0)
        if rate <= 0:
            raise LipSyncError(f"eSpeak NG could not start with its data in {data}")
        _LIB, _RATE = lib, rate
        return lib


def version() -> str:
    lib = _library()
    path = ctypes.c_char_p()
    return lib.espeak_Info(ctypes.byref(path)).decode()


def _set_voice(voice: str) -> None:
    global _VOICE
    if voice == _VOICE:
        return
    if _library().espeak_SetVoiceByName(voice.encode("utf-8")) != 0:
        raise LipSyncError(f"eSpeak NG has no voice {voice!r}")
    _VOICE = voice


def ipa_words(text: str, voice: str) -> list[list[str]]:
    """The IPA phonemes of each word eSpeak hears in ``text``, read with
    ``voice`` (stress marks and length kept; its language-switch marks such
    as ``(en)`` dropped)."""
    with _LOCK:
        lib = _library()
        _set_voice(voice)
        buf = ctypes.create_string_buffer(text.encode("utf-8"))
        ptr = ctypes.c_void_p(ctypes.addressof(buf))
        words: list[list[str]] = []
        while ptr.value:
            out = lib.espeak_TextToPhonemes(ctypes.byref(ptr), _CHARS_UTF8, _PHONEMES_IPA | (ord(_SEPARATOR) << 8))
            if not out:
                break
            for group in _SWITCH.sub("", out.decode("utf-8", "replace")).split():
                units = [u for u in group.split(_SEPARATOR) if u.strip()]
                if units:
                    words.append(units)
        return words


_STRESS = set("ˈˌ")


def _clean(unit: str) -> str:
    """A phoneme without marks :mod:`.ipa` does not read and that show nothing
    (eSpeak's modifier letters such as the ``ᵝ`` of Japanese ``ɯᵝ``)."""
    out = []
    for ch in unicodedata.normalize("NFC", unit):
        if ch in _STRESS:
            continue
        if unicodedata.category(ch) in ("Lm", "Sk") and ch not in ipa.MODIFIERS:
            continue
        out.append(ch)
    return "".join(out)


def unit_phones(unit: str, fixes: dict | None = None) -> list[str]:
    """The engine's phones for one eSpeak phoneme (IPA)."""
    unit = _clean(unit)
    if fixes:
        if unit in fixes:
            unit = fixes[unit]
        else:
            for name in sorted(fixes, key=len, reverse=True):
                if name and name in unit:
                    unit = unit.replace(name, fixes[name])
    unit = unit.strip()
    if not unit:
        return []
    try:
        return ipa.to_arpabet(unit)
    except ipa.UnknownSymbol:
        # A symbol eSpeak writes that ipa.json has no features for: keep the rest
        # (nothing when only marks are left, such as a lone palatalisation ʲ).
        kept = "".join(ch for ch in unit if _reads(ch))
        try:
            return ipa.to_arpabet(kept) if kept else []
        except ipa.UnknownSymbol:
            return []


def _reads(ch: str) -> bool:
    try:
        ipa.to_arpabet("a" + ch)
        return True
    except ipa.UnknownSymbol:
        return False


def to_phones(units: list[str], fixes: dict | None = None) -> list[str]:
    """The engine's phones for a word's eSpeak phonemes; a phone repeated
    across two phonemes (a geminate, Japanese ``n n``) is one phone."""
    out: list[str] = []
    for unit in units:
        for p in unit_phones(unit, fixes):
            if not out or out[-1] != p:
                out.append(p)
    return out


def pronounce(text: str, voice: str, fixes: dict | None = None) -> list[str]:
    """The engine's phones for one written word (or number, or run of
    characters) read with ``voice``."""
    phones = [p for units in ipa_words(text, voice) for p in to_phones(units, fixes)]
    if not phones:
        raise TranscriptError(f"eSpeak NG ({voice}) gives no sounds for {text!r}")
    out: list[str] = []
    for p in phones:
        if not out or out[-1] != p:
            out.append(p)
    return out


def synthesize(text: str, voice: str, rate: int = 160):
    """``text`` spoken by eSpeak NG's ``voice``: (int16 samples, sample rate)."""
    import numpy as np

    chunks: list = []

    def collect(wav, n, events):
        if wav and n > 0:
            chunks.append(np.ctypeslib.as_array(wav, shape=(n,)).copy())
        return 0

    callback = _SYNTH_CALLBACK(collect)
    with _LOCK:
        lib = _library()
        _set_voice(voice)
        lib.espeak_SetParameter(1, int(rate), 0)   # espeakRATE, words per minute
        lib.espeak_SetSynthCallback(callback)
        data = text.encode("utf-8")
        buf = ctypes.create_string_buffer(data)
        flags = 0   # espeakCHARS_AUTO
        if lib.espeak_Synth(buf, len(data) + 1, 0, 1, 0, flags, None, None) != 0:
            raise LipSyncError(f"eSpeak NG could not speak {text!r}")
        lib.espeak_Synchronize()
        lib.espeak_SetSynthCallback(_SYNTH_CALLBACK(0))
    samples = np.concatenate(chunks) if chunks else np.zeros(0, np.int16)
    return samples, _RATE
