"""Speech with no transcript: a stretch of loud speech the recogniser heard no
word in is shown as a hesitation ("uh"), not at rest; a breath, a click or a
word's decay is not."""

from __future__ import annotations

import numpy as np

from addon.engine.alignment import recognize
from addon.engine.alignment.model import AlignedPhone, AlignedWord
from addon.engine.alignment.speech import speech_or_refuse
from addon.engine.audio import Audio

RATE = 16000


def _voice(seconds: float, level: float = 0.3) -> np.ndarray:
    """A voiced, vowel-like sound: harmonics of 120 Hz."""
    t = np.arange(int(seconds * RATE)) / RATE
    return level * sum(np.sin(2 * np.pi * 120 * k * t) / k for k in range(1, 20)).astype(np.float32) / 3


def _clip(*parts) -> Audio:
    return Audio(np.concatenate([p if isinstance(p, np.ndarray) else np.zeros(int(p * RATE), np.float32)
                                 for p in parts]).astype(np.float32), RATE)


def _mask(snd: Audio) -> np.ndarray:
    return speech_or_refuse(snd)[1]


def _heard(spans):
    """Recognised words on ``spans`` (s), each one phone AH."""
    words = [AlignedWord(f"w{k}", a, b, ["AH"], "recognized", recognized=True) for k, (a, b) in enumerate(spans)]
    return words, [AlignedPhone("AH", a, b, k) for k, (a, b) in enumerate(spans)]


def test_loud_speech_between_the_words_heard_is_an_uh():
    # 0.3 s silence | word 0.5 s | 0.4 s of speech no word was heard in | word 0.5 s | silence
    snd = _clip(0.3, _voice(0.5), _voice(0.4), _voice(0.5), 0.3)
    words, phones = _heard([(0.3, 0.8), (1.2, 1.7)])
    out_w, out_p = recognize.with_hesitations(snd, _mask(snd), words, phones)
    assert [w.text for w in out_w] == ["w0", "uh", "w1"]
    uh = out_w[1]
    assert uh.recognized and uh.estimated and uh.phones == ["AH"]
    assert 0.8 <= uh.start <= 0.85 and 1.15 <= uh.end <= 1.2
    # Every phone counts in the returned words.
    assert [(p.phone, p.word_index) for p in out_p] == [("AH", 0), ("AH", 1), ("AH", 2)]
    assert out_p[1].start == uh.start and out_p[1].end == uh.end


def test_a_short_or_quiet_sound_between_the_words_stays_at_rest():
    short = _clip(0.3, _voice(0.5), 0.2, _voice(0.15), 0.2, _voice(0.5), 0.3)   # a click-like 0.15 s
    words, phones = _heard([(0.3, 0.8), (1.35, 1.85)])
    assert [w.text for w in recognize.with_hesitations(short, _mask(short), words, phones)[0]] == ["w0", "w1"]
    quiet = _clip(0.3, _voice(0.5), _voice(0.4, level=0.003), _voice(0.5), 0.3)   # a breath 40 dB down
    words, phones = _heard([(0.3, 0.8), (1.2, 1.7)])
    assert [w.text for w in recognize.with_hesitations(quiet, _mask(quiet), words, phones)[0]] == ["w0", "w1"]


def test_no_transcript_says_how_many_stretches_were_shown_as_uh(monkeypatch):
    snd = _clip(0.3, _voice(0.5), _voice(0.4), _voice(0.5), 0.3)
    monkeypatch.setattr(recognize, "recognize_spans", lambda *a, **k: _heard([(0.3, 0.8), (1.2, 1.7)]))
    al = recognize.recognize(snd)
    assert [w.text for w in al.words] == ["w0", "uh", "w1"]
    assert "2 words; 1 stretch of speech with no word heard in it shown as 'uh'" in al.notes[0]
    assert not al.warnings
