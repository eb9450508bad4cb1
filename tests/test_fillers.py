"""Hesitations may be decoded as a filler sound (alignment.fillers)."""

import numpy as np

from conftest import FIXTURES
from voice_synth import _resonator
from addon.engine import audio as audio_mod
from addon.engine.alignment.fillers import (FILLER, Hesitation, base_token, dictionary_lines, is_hesitation,
                                            mark, prefer, restore)
from addon.engine.alignment import align_audio


def test_which_words_are_hesitations():
    assert all(is_hesitation(w) for w in ("uh", "Uhh", "er", "ah", "eh"))
    # Words, and hesitations with a hum (their /m/ closes the lips), are not.
    assert not any(is_hesitation(w) for w in ("a", "the", "um", "hmm", "mm", "huh", "her"))


def test_dictionary_offers_the_filler_for_hesitations_only():
    prons = mark([["AH"], ["AH"]], ["uh", "a"])
    assert isinstance(prons[0], Hesitation) and not isinstance(prons[1], Hesitation)
    assert dictionary_lines("w0", prons[0], fillers=True) == ["w0 AH", f"w0(2) {FILLER}"]
    assert dictionary_lines("w0", prons[0]) == ["w0 AH"]
    assert dictionary_lines("w1", prons[1], fillers=True) == ["w1 AH"]
    assert base_token("w0(2)") == "w0" and base_token("w12") == "w12"


def test_restore_gives_the_word_its_phones_back():
    result = [[("B", 0.0, 0.1)], [(FILLER, 0.2, 0.5)], None]
    restore(result, [["B"], ["ER"], ["AH"]])
    assert result[0] == [("B", 0.0, 0.1)]
    assert result[1] == [("ER", 0.2, 0.5)]
    assert result[2] is None


def test_the_filler_decode_must_cover_clearly_more_speech():
    mask = np.zeros(100, bool)
    mask[10:30] = mask[60:80] = True
    plain = ("words", 2, [(10, 30), (40, 45)])            # the second word on silence
    fillers = ("phones", 2, [[("B", 10, 30)], [(FILLER, 60, 80)]])
    assert prefer(plain, fillers, mask, 5) is fillers
    assert prefer(plain, ("words", 2, [(10, 30), (58, 63)]), mask, 5) is plain
    assert prefer(plain, ("failed", 0, "no"), mask, 5) is plain
    assert prefer(("failed", 0, "no"), fillers, mask, 5) is fillers


def test_whispered_hesitation_between_two_phrases():
    """A whispered "uh" between two phrases: the hesitation lies on it, with
    its own phone (the filler, which fits the release of "map" better, is
    not allowed to pull it there), and every word stays in order."""
    snd = audio_mod.load(FIXTURES / "bob_map.wav")
    rng = np.random.default_rng(5)
    noise = rng.standard_normal(int(0.4 * snd.rate))
    whisper = sum(_resonator(noise, f, bw) for f, bw in ((600, 150), (1200, 200), (2500, 300)))
    whisper *= 0.1 * np.abs(snd.samples).max() / np.abs(whisper).max() * np.hanning(len(whisper))
    gap = np.zeros(int(0.5 * snd.rate))
    joined = audio_mod.Audio(np.concatenate([snd.samples, gap, whisper, gap, snd.samples]).astype(np.float32),
                             snd.rate)
    al = align_audio(joined, "Bob bought a map, uh, Bob bought a map.")
    uh = al.words[4]
    start = (len(snd.samples) + len(gap)) / snd.rate
    assert uh.text == "uh" and start - 0.05 <= uh.start and uh.end <= start + 0.45
    assert [p.phone for p in al.phones if p.word_index == 4] == ["AH"]
    starts = [p.start for p in al.phones]
    assert starts == sorted(starts)


def test_the_decoder_accepts_the_filler_pronunciation():
    from addon.engine.alignment.decoding import _decoder
    from addon.engine.alignment.model import AlignSettings

    assert _decoder([Hesitation(["AH"]), ["B", "AA", "B"]], 0, AlignSettings(), fillers=True) is not None
