"""Words read from IPA start where their sound does (alignment.onsets), and
keep their own corrections: no move to a stop's burst, their own boundary
offsets; English words keep theirs."""

from pathlib import Path

import numpy as np

from addon.engine.alignment.boundaries import shift_boundaries
from addon.engine.alignment.bursts import refine_stops
from addon.engine.alignment.onsets import place_onsets, sound_onset
from addon.engine.audio import Audio

RATE = 16000
FIXTURES = Path(__file__).parent / "fixtures"


def _word_after_silence(onset: float = 0.2, length: float = 0.6, hum: float = 0.0, hiss: float = 0.0,
                        burst_at: float | None = None) -> Audio:
    """Faint noise (with a mains ``hum`` at 50 Hz and a ``hiss`` above 5 kHz if
    asked), then from ``onset`` a voice (harmonics of 120 Hz) to the end; with
    ``burst_at``, a 10 ms broadband burst there inside the voice (a prevoiced
    stop's release)."""
    rng = np.random.default_rng(5)
    t = np.arange(int(length * RATE)) / RATE
    x = 0.0005 * rng.standard_normal(len(t))
    x += hum * np.sin(2 * np.pi * 50 * t)
    if hiss:
        x += hiss * np.sin(2 * np.pi * 5600 * t) * rng.standard_normal(len(t))
    on = t >= onset
    x[on] += sum(0.1 / k * np.sin(2 * np.pi * 120 * k * t[on]) for k in range(1, 25))
    if burst_at is not None:
        b0, b1 = int(burst_at * RATE), int((burst_at + 0.01) * RATE)
        x[b0:b1] += 0.3 * rng.standard_normal(b1 - b0)
    return Audio(x.astype(np.float32), RATE)


def test_the_onset_is_where_the_voice_becomes_audible():
    t = sound_onset(_word_after_silence(0.2), 0.0, 0.5)
    assert t is not None and abs(t - 0.2) <= 0.012


def test_hum_and_hiss_of_the_silence_are_not_the_onset():
    # A mains hum and a hiss as loud as the voice's weaker harmonics fill the silence, outside the band.
    snd = _word_after_silence(0.2, hum=0.05, hiss=0.01)
    t = sound_onset(snd, 0.0, 0.5)
    assert t is not None and abs(t - 0.2) <= 0.012


def test_no_onset_inside_steady_sound():
    snd = _word_after_silence(0.1)
    assert sound_onset(snd, 0.3, 0.5) is None


def test_first_phone_of_a_word_from_ipa_starts_at_the_onset():
    snd = _word_after_silence(0.2)
    result = [[("M", 0.12, 0.28), ("AA", 0.28, 0.55)]]
    place_onsets(snd, result, [False], [True])
    assert abs(result[0][0][1] - 0.2) <= 0.012
    assert result[0][0][2] == 0.28 and result[0][1] == ("AA", 0.28, 0.55)
    # Aligned late: the onset is searched before the aligned start too.
    result = [[("M", 0.27, 0.36), ("AA", 0.36, 0.55)]]
    place_onsets(snd, result, [False], [True])
    assert abs(result[0][0][1] - 0.2) <= 0.012


def test_english_estimated_and_joined_words_keep_their_start():
    snd = _word_after_silence(0.2)
    for from_ipa, estimated in (([False], [False]), ([True], [True])):
        result = [[("M", 0.12, 0.28), ("AA", 0.28, 0.55)]]
        place_onsets(snd, result, estimated, from_ipa)
        assert result[0][0] == ("M", 0.12, 0.28)
    # Right after another word (no pause): its start is that word's end, not a silence's.
    result = [[("AH", 0.05, 0.12)], [("M", 0.12, 0.28), ("AA", 0.28, 0.55)]]
    place_onsets(snd, result, [False, False], [True, True])
    assert result[1][0] == ("M", 0.12, 0.28)


def test_the_first_phone_keeps_its_shortest_length():
    snd = _word_after_silence(0.2)
    result = [[("M", 0.1, 0.21), ("AA", 0.21, 0.55)]]
    place_onsets(snd, result, [False], [True])
    assert result[0][0][1] <= 0.21 - 0.03 + 1e-9


def test_a_prevoiced_stop_from_ipa_keeps_its_prevoicing():
    # The voice starts at 0.2 s and the release burst comes at 0.26 s: English moves the stop to its
    # burst; read from IPA, the stop starts with its voicing.
    snd = _word_after_silence(0.2, burst_at=0.26)
    english = [[("B", 0.15, 0.27), ("AA", 0.27, 0.55)]]
    refine_stops(snd, english, [False])
    assert abs(english[0][0][1] - 0.26) <= 0.005
    other = [[("B", 0.15, 0.27), ("AA", 0.27, 0.55)]]
    refine_stops(snd, other, [False], [True])
    assert other[0][0] == ("B", 0.15, 0.27)
    place_onsets(snd, other, [False], [True])
    assert abs(other[0][0][1] - 0.2) <= 0.012


def test_words_from_ipa_take_their_own_boundary_offsets():
    english = {"shift": {"vowel>nasal": 0.01}, "default": 0.0, "min_phone": 0.03}
    ipa = {"shift": {"vowel>nasal": 0.03}, "default": 0.0}

    def line():
        return [[("AA", 0.1, 0.3), ("M", 0.3, 0.5)], [("AA", 0.6, 0.8), ("M", 0.8, 1.0)]]

    result = line()
    shift_boundaries(None, result, [False, False], english, from_ipa=[False, True], ipa_cfg=ipa)
    assert result[0][1][1] == 0.31 and result[0][0][2] == 0.31     # English: 10 ms
    assert abs(result[1][1][1] - 0.83) < 1e-9                      # read from IPA: 30 ms
    plain = line()
    shift_boundaries(None, plain, [False, False], english)
    assert plain[0] == result[0] and plain[1][1][1] == 0.81


def test_digital_silence_is_not_the_quiet_level():
    # A gated edit: zeros, then the room's noise, then the voice; the noise is not the onset.
    snd = _word_after_silence(0.3, length=0.9)
    x = snd.samples.copy()
    x[:int(0.1 * RATE)] = 0.0
    x[int(0.6 * RATE):] = 0.0
    t = sound_onset(Audio(x, RATE), 0.05, 0.5)
    assert t is not None and abs(t - 0.3) <= 0.012


def test_the_aligner_starts_a_word_from_ipa_at_its_voicing_and_an_english_one_at_its_burst():
    from addon.engine import audio as audio_mod
    from addon.engine.alignment import core

    # "Bob bought a map." after 0.34 s of faint noise and 60 ms of voicing (harmonics of 120 Hz) before
    # its first /b/ is released: a prevoiced /b/.
    bob = audio_mod.load(FIXTURES / "bob_map.wav")
    rng = np.random.default_rng(1)
    t = np.arange(int(0.06 * RATE)) / RATE
    voicing = sum(0.02 / k * np.sin(2 * np.pi * 120 * k * t) for k in range(1, 8))
    x = np.concatenate([0.0003 * rng.standard_normal(int(0.34 * RATE)), voicing, bob.samples[int(0.015 * RATE):]])
    snd = Audio(x.astype(np.float32), RATE)
    phones = [["B", "AA", "B"], ["B", "AA", "T"], ["AH"], ["M", "AE", "P"]]
    ipa = core.align(snd, phones, sources=["ipa"] * 4)
    english = core.align(snd, phones, sources=["cmudict"] * 4)
    assert abs(ipa.phones[0].start - 0.34) <= 0.012          # with its voicing
    assert english.phones[0].start >= 0.39                    # at its release
    unmarked = core.align(snd, phones)
    assert [(p.phone, p.start, p.end) for p in unmarked.phones] == [(p.phone, p.start, p.end) for p in english.phones]


def _hiss_then_voice(hiss_at: float = 0.2, voice_at: float = 0.4, click_at: float | None = None) -> Audio:
    """Faint noise; from ``hiss_at`` a hiss between 4.5 and 7.5 kHz (a sibilant, which the band of
    the voice's onset does not hear); from ``voice_at`` a voice over it; with ``click_at``, a 5 ms
    click there (a lip smack)."""
    rng = np.random.default_rng(7)
    n = int(0.7 * RATE)
    t = np.arange(n) / RATE
    x = 0.0005 * rng.standard_normal(n)
    spec = np.fft.rfft(rng.standard_normal(n))
    f = np.fft.rfftfreq(n, 1 / RATE)
    spec[(f < 4500) | (f > 7500)] = 0
    hiss = np.fft.irfft(spec, n)
    hiss *= 0.03 / hiss.std()
    x[t >= hiss_at] += hiss[t >= hiss_at]
    on = t >= voice_at
    x[on] += sum(0.1 / k * np.sin(2 * np.pi * 120 * k * t[on]) for k in range(1, 25))
    if click_at is not None:
        c0 = int(click_at * RATE)
        x[c0:c0 + int(0.005 * RATE)] += 0.3 * rng.standard_normal(int(0.005 * RATE))
    return Audio(x.astype(np.float32), RATE)


def test_a_fricative_from_ipa_starts_where_its_hiss_does():
    # /sa/ aligned late (the silence took the start of the /s/): the /s/ starts with its hiss.
    snd = _hiss_then_voice(0.2, 0.4)
    result = [[("S", 0.33, 0.4), ("AA", 0.4, 0.65)]]
    place_onsets(snd, result, [False], [True])
    assert abs(result[0][0][1] - 0.2) <= 0.012 and result[0][0][2] == 0.4
    # A click before the hiss is not its onset.
    snd = _hiss_then_voice(0.2, 0.4, click_at=0.12)
    result = [[("S", 0.33, 0.4), ("AA", 0.4, 0.65)]]
    place_onsets(snd, result, [False], [True])
    assert abs(result[0][0][1] - 0.2) <= 0.012


def test_hiss_before_a_word_that_starts_with_a_vowel_is_not_its_start():
    # A breath's hiss before /a/: the vowel starts with the voice, not with the hiss.
    snd = _hiss_then_voice(0.2, 0.4)
    result = [[("AA", 0.38, 0.65)]]
    place_onsets(snd, result, [False], [True])
    assert abs(result[0][0][1] - 0.4) <= 0.012
    # An English word keeps its aligned start.
    result = [[("S", 0.33, 0.4), ("AA", 0.4, 0.65)]]
    place_onsets(snd, result, [False], [False])
    assert result[0][0] == ("S", 0.33, 0.4)
