"""Phone boundaries corrected by the classes of the phones they join (alignment.boundaries)."""

from pathlib import Path

import numpy as np
import pytest

from addon.engine import audio as audio_mod
from addon.engine import pauses
from addon.engine.audio import Audio
from addon.engine.alignment import boundaries, core
from addon.engine.alignment.boundaries import boundary_class, shift_boundaries, voice_onset

RATE = 16000
FIXTURES = Path(__file__).parent / "fixtures"
CFG = {"default": 0.005, "min_phone": 0.015, "onset_rise": 20.0,
       "shift": {"vowel>fricative": 0.015, "plosive>glide": 0.03, "vowel>vowel": 0.0, "start>vowel": 0.045,
                 "gap>vowel": 0.0, "nasal>vowel": -0.005}}


def _clip(voice_from: float, length: float = 0.6) -> Audio:
    """Faint noise, and a vowel (harmonics of 120 Hz) from ``voice_from`` s."""
    rng = np.random.default_rng(5)
    t = np.arange(int(length * RATE)) / RATE
    x = 0.0005 * rng.standard_normal(len(t))
    on = t >= voice_from
    x[on] += sum(0.1 / k * np.sin(2 * np.pi * 120 * k * t[on]) for k in range(1, 25))
    return Audio(x.astype(np.float32), RATE)


QUIET = _clip(0.3)


def test_classes():
    assert [boundary_class(p) for p in ("AA", "S", "CH", "HH", "P", "M", "L", "W", "Y")] == \
        ["vowel", "fricative", "fricative", "fricative", "plosive", "nasal", "liquid", "glide", "glide"]
    assert boundary_class(None, first=True) == "start" and boundary_class(None) == "gap"
    assert boundary_class("SIL") is None


def test_a_boundary_moves_by_its_pair_and_the_phone_before_follows():
    result = [[("M", 0.30, 0.36), ("AA", 0.36, 0.50), ("S", 0.50, 0.62)], [("P", 0.62, 0.70), ("W", 0.70, 0.80)]]
    shift_boundaries(QUIET, result, [False, False], CFG)
    assert result[0][1] == ("AA", pytest.approx(0.355), pytest.approx(0.515))
    assert result[0][0] == ("M", 0.30, pytest.approx(0.355))          # nasal>vowel: 5 ms earlier
    assert result[0][2] == ("S", pytest.approx(0.515), pytest.approx(0.625))   # vowel>fricative: 15 ms later
    assert result[1][0] == ("P", pytest.approx(0.625), pytest.approx(0.73))    # fricative>plosive: the default
    assert result[1][1] == ("W", pytest.approx(0.73), 0.80)                    # plosive>glide: 30 ms later


def test_a_pair_at_zero_and_estimated_words_are_left_alone():
    result = [[("AA", 0.30, 0.40), ("IY", 0.40, 0.50)], [("S", 0.50, 0.60)], [("AA", 0.60, 0.70)]]
    shift_boundaries(QUIET, result, [False, True, False], CFG)
    assert result == [[("AA", 0.30, 0.40), ("IY", 0.40, 0.50)], [("S", 0.50, 0.60)], [("AA", 0.60, 0.70)]]


def test_after_a_pause_the_gap_entry_applies_and_the_phone_before_stays():
    result = [[("AA", 0.30, 0.40)], [("AA", 0.55, 0.70), ("S", 0.70, 0.80)]]
    shift_boundaries(QUIET, result, [False, False], dict(CFG, shift=dict(CFG["shift"], **{"gap>vowel": 0.02})))
    assert result[0][0] == ("AA", 0.30, 0.40)
    assert result[1][0] == ("AA", pytest.approx(0.57), pytest.approx(0.715))


def test_no_phone_shrinks_below_its_least_length():
    # S is 20 ms long: a 15 ms later start would leave it 5 ms, so it keeps 15 ms.
    result = [[("AA", 0.30, 0.40), ("S", 0.40, 0.42), ("AA", 0.42, 0.50)]]
    shift_boundaries(QUIET, result, [False], dict(CFG, shift={"vowel>fricative": 0.015}, default=0.0))
    assert result[0][1] == ("S", pytest.approx(0.405), 0.42) and result[0][0][2] == pytest.approx(0.405)
    # A phone already shorter than that keeps its start (the limit would move it the wrong way).
    result = [[("AA", 0.30, 0.40), ("S", 0.40, 0.41)]]
    shift_boundaries(QUIET, result, [False], dict(CFG, shift={"vowel>fricative": 0.015}, default=0.0))
    assert result == [[("AA", 0.30, 0.40), ("S", 0.40, 0.41)]]


def test_voice_onset():
    assert voice_onset(_clip(0.2), 0.1, 0.4, 20.0) == pytest.approx(0.2, abs=0.01)
    assert voice_onset(_clip(0.0), 0.0, 0.4, 20.0) == 0.0
    assert voice_onset(_clip(0.5), 0.1, 0.3, 20.0) == 0.3
    # Far into a long clip (only the audio around the span is measured).
    assert voice_onset(_clip(30.2, length=40.0), 30.1, 30.4, 20.0) == pytest.approx(30.2, abs=0.01)


def test_the_first_phone_moves_toward_the_voice_not_past_it():
    # Silence, then the voice at 0.20 s: an aligned start at 0.14 s moves the whole offset (45 ms) ...
    result = [[("AA", 0.14, 0.40)]]
    shift_boundaries(_clip(0.20), result, [False], CFG)
    assert result[0][0][1] == pytest.approx(0.185)
    # ... one at 0.17 s stops at the voice ...
    result = [[("AA", 0.17, 0.40)]]
    shift_boundaries(_clip(0.20), result, [False], CFG)
    assert 0.19 <= result[0][0][1] <= 0.205
    # ... and a clip cut tight on its first word keeps its start.
    result = [[("AA", 0.0, 0.40)]]
    shift_boundaries(_clip(0.0), result, [False], CFG)
    assert result[0][0][1] == 0.0


def test_the_shipped_settings_are_read_from_timing_json():
    shipped = pauses.settings()["boundary"]
    assert boundaries._settings() == shipped
    off = shipped["shift"]["vowel>fricative"]
    assert off > 0
    result = [[("AA", 0.30, 0.40), ("S", 0.40, 0.55)]]
    shift_boundaries(QUIET, result, [False])
    assert result[0][1][1] == pytest.approx(0.40 + off)
    # "atmosphere" with the shipped settings: the lips close min_phone after the /t/ starts.
    result = [[("AE", 0.30, 0.42), ("T", 0.42, 0.49), ("M", 0.49, 0.55), ("AH", 0.55, 0.60)]]
    shift_boundaries(QUIET, result, [False])
    assert result[0][1][1] == 0.42 and result[0][2][1] == pytest.approx(0.42 + shipped["min_phone"])
    # Every named pair is a pair of known classes, and each offset is small.
    known = {"start", "gap", "vowel", "plosive", "fricative", "nasal", "liquid", "glide"}
    for pair, value in shipped["shift"].items():
        left, right = pair.split(">")
        assert left in known and right in known - {"start", "gap"} and abs(value) <= 0.06


def test_the_aligner_corrects_its_boundaries_last(monkeypatch):
    snd = audio_mod.load(FIXTURES / "bob_map.wav")
    text = (FIXTURES / "bob_map.txt").read_text()
    corrected = core.align(snd, _phones(text))
    seen = {}

    def record(audio, result, estimated):
        seen["result"] = [list(w) if w else w for w in result]
        seen["estimated"] = list(estimated)

    monkeypatch.setattr(core, "shift_boundaries", record)
    plain = core.align(snd, _phones(text))
    assert [(p.phone, p.start) for p in plain.phones] != [(p.phone, p.start) for p in corrected.phones]
    shift_boundaries(snd, seen["result"], seen["estimated"])
    again = [(p, round(a, 6), round(b, 6)) for w in seen["result"] for p, a, b in w]
    assert again == [(p.phone, round(p.start, 6), round(p.end, 6)) for p in corrected.phones]


def _phones(text):
    from addon.engine.language import Lexicon, normalize

    lex = Lexicon()
    return [lex.pronounce(w).phones for w in normalize(text)]


UNRELEASED = dict(CFG, min_phone=0.03, unreleased={"stops": ["T"], "before": ["P", "B", "M"]},
                  shift=dict(CFG["shift"], **{"vowel>plosive": 0.01, "plosive>plosive": 0.035, "plosive>nasal": 0.02}))


def test_a_t_run_into_a_labial_lasts_the_least_length_and_the_lips_close_after_it():
    # "atmosphere": AE T M, the T aligned 50 ms long: no offset moves its start, the M starts 30 ms after it
    # (and ends where nasal>vowel puts it).
    result = [[("AE", 0.30, 0.42), ("T", 0.42, 0.47), ("M", 0.47, 0.55), ("AH", 0.55, 0.60)]]
    shift_boundaries(QUIET, result, [False], UNRELEASED)
    assert result[0][:3] == [("AE", 0.30, 0.42), ("T", 0.42, pytest.approx(0.45)),
                             ("M", pytest.approx(0.45), pytest.approx(0.545))]
    # "it pays": a T already 30 ms long keeps its place, and plosive>plosive (35 ms) does not push the P later.
    result = [[("IH", 0.30, 0.40), ("T", 0.40, 0.43)], [("P", 0.43, 0.52), ("EY", 0.52, 0.70)]]
    shift_boundaries(QUIET, result, [False, False], UNRELEASED)
    assert result[0][1] == ("T", 0.40, 0.43) and result[1][0][:2] == ("P", 0.43)


def test_other_stops_before_a_labial_and_a_t_before_other_phones_take_their_offsets():
    result = [[("AE", 0.30, 0.42), ("D", 0.42, 0.47), ("M", 0.47, 0.55)]]
    shift_boundaries(QUIET, result, [False], UNRELEASED)
    assert result[0] == [("AE", 0.30, pytest.approx(0.43)), ("D", pytest.approx(0.43), pytest.approx(0.49)),
                         ("M", pytest.approx(0.49), 0.55)]
    result = [[("AE", 0.30, 0.42), ("T", 0.42, 0.47), ("K", 0.47, 0.55)]]
    shift_boundaries(QUIET, result, [False], UNRELEASED)
    assert result[0][1] == ("T", pytest.approx(0.43), pytest.approx(0.505))
    # A T before a labial across a pause, or next to an estimated word, is left to the table (or alone).
    result = [[("AE", 0.30, 0.42), ("T", 0.42, 0.47)], [("M", 0.60, 0.70)]]
    shift_boundaries(QUIET, result, [False, False], UNRELEASED)
    assert result[0][1] == ("T", pytest.approx(0.43), 0.47)
    result = [[("AE", 0.30, 0.42), ("T", 0.42, 0.47)], [("M", 0.47, 0.70)]]
    shift_boundaries(QUIET, result, [False, True], UNRELEASED)
    assert result == [[("AE", 0.30, pytest.approx(0.43)), ("T", pytest.approx(0.43), 0.47)], [("M", 0.47, 0.70)]]
