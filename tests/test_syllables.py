"""Cheap evidence before recognition: the checks of a take recognise a
stretch of uncovered speech only where its level rises and falls as words
do (two syllables or more).  A breath, a hum or a held vowel is one peak
and costs no recognition."""

from __future__ import annotations

import numpy as np

from addon.engine import audio as audio_mod
from addon.engine.alignment import verify
from addon.engine.alignment.speech import syllable_peaks
from conftest import SAMPLE
from voice_synth import voice

RATE = 16000


def _bumps(heights, dip: float, width: int = 12) -> np.ndarray:
    """Frame levels (dB): one raised-cosine bump of each height, ``dip`` dB
    down between them."""
    out = []
    for h in heights:
        out.append(h - dip + dip * np.sin(np.pi * np.arange(width) / (width - 1)))
    return np.concatenate(out)


def test_syllable_peaks_counts_the_rises_and_falls_that_stand_out():
    assert syllable_peaks(_bumps([-20, -22, -21], dip=8.0), floor=-40.0, prominence=2.0) == 3
    # Ripples of a dB on one sound are one syllable.
    ripple = -20 + np.sin(np.linspace(0, 8 * np.pi, 60)) * 0.4 - 6 * np.linspace(-1, 1, 60) ** 2
    assert syllable_peaks(ripple, floor=-40.0, prominence=2.0) == 1
    # Peaks below the floor (room noise, a quiet breath) are not syllables.
    assert syllable_peaks(_bumps([-20, -55], dip=8.0), floor=-40.0, prominence=2.0) == 1
    # A dip too shallow to part two syllables at this prominence: one sound, between silences.
    quiet = np.full(10, -60.0)
    shallow = np.concatenate([quiet, _bumps([-20, -20.3], dip=1.5), quiet])
    assert syllable_peaks(shallow, floor=-40.0, prominence=2.0) == 1
    assert syllable_peaks(shallow, floor=-40.0, prominence=1.0) == 2
    assert syllable_peaks(np.zeros(0), floor=-40.0, prominence=2.0) == 0
    # A syllable cut off by the stretch's end, still rising, is one where it is as loud as the voice
    # (not the rise into a word just after the stretch).
    cut = np.concatenate([_bumps([-20], dip=8.0), _bumps([-18], dip=8.0)[:6]])
    assert syllable_peaks(cut, floor=-40.0, prominence=2.0, cut_floor=-25.0) == 2
    assert syllable_peaks(cut, floor=-40.0, prominence=2.0, cut_floor=-15.0) == 1


def _held_vowel(seconds: float = 1.2) -> np.ndarray:
    snd, _ = voice(0.5, syllables=("AA",), syl=seconds, gap=0.0, lead=0.0)
    x = np.asarray(snd.samples, np.float64)
    n = len(x)
    # A held vowel: the syllable's rise and fall replaced by a steady level with soft edges.
    env = np.minimum(1.0, np.minimum(np.arange(n), n - np.arange(n)) / (0.08 * RATE))
    steady = x / np.maximum(1e-3, np.abs(np.convolve(x, np.ones(400) / 400, mode="same"))) * env
    return steady / np.abs(steady).max() * 0.3


def test_words_are_listened_for_in_speech_not_in_a_held_vowel(monkeypatch):
    line = audio_mod.load(SAMPLE / "hello.wav")
    x = np.asarray(line.samples, np.float64)
    held = _held_vowel()
    gap = np.zeros(int(0.5 * RATE))
    snd = audio_mod.Audio(np.concatenate([x, gap, held, gap]).astype(np.float32), RATE)
    t = (len(x) + len(gap)) / RATE
    speech, vowel = (0.3, line.duration - 0.3), (t, t + len(held) / RATE)
    assert verify.may_hold_words(snd, [speech, vowel]) == [True, False]

    asked = []

    def recognize_spans(audio, spans, settings=None, progress=None, check=False, fewest=0):
        asked.extend(spans)
        return [], []

    monkeypatch.setattr(verify, "recognize_spans", recognize_spans)
    assert verify.words_heard(snd, [speech, vowel], None) == [False, False]
    assert asked == [speech]      # the held vowel is not recognised
    # Were every ripple a syllable, the held vowel would be recognised too.
    monkeypatch.setattr(verify, "SYLLABLE_DB", 0.0)
    asked.clear()
    assert verify.words_heard(snd, [speech, vowel], None) == [False, False]
    assert asked == [speech, vowel]


def test_a_stretch_with_too_few_words_heard_has_no_phones_aligned(monkeypatch):
    """The checks count the words heard in a stretch: where fewer than they
    need are heard, the recogniser's phone pass is skipped, and nothing is
    returned (a stretch of one word is not heard either way)."""
    from addon.engine.alignment import recognize

    line = audio_mod.load(SAMPLE / "hello.wav")
    span = (0.0, line.duration)
    passes = []
    real = recognize.phone_alignment

    def phone_alignment(decoder, pcm):
        passes.append(len(pcm))
        return real(decoder, pcm)

    monkeypatch.setattr(recognize, "phone_alignment", phone_alignment)
    words, phones = recognize.recognize_spans(line, [span], check=True)
    assert len(words) >= verify.MIN_HEARD_WORDS and phones and len(passes) == 1
    assert verify._heard(words, *span)
    # Asked for more words than are heard: none returned, no phone pass.
    passes.clear()
    assert recognize.recognize_spans(line, [span], check=True, fewest=len(words) + 1) == ([], [])
    assert passes == []
    # Asked for as many as are heard: the same words and phones as without asking.
    again = recognize.recognize_spans(line, [span], check=True, fewest=len(words))
    assert [(w.text, w.start, w.end) for w in again[0]] == [(w.text, w.start, w.end) for w in words]
    assert len(passes) == 1
