"""Stops after silence start at their release burst (alignment.bursts)."""

import numpy as np

from addon.engine.audio import Audio
from addon.engine.alignment.bursts import burst_time, refine_stops

RATE = 16000


def _prevoiced_stop(burst_at: float = 0.065, length: float = 0.3) -> Audio:
    """Faint noise, then prevoicing (a low hum) from 15 ms, a 10 ms broadband
    burst at ``burst_at`` and a vowel (harmonics of 120 Hz) after it."""
    rng = np.random.default_rng(3)
    t = np.arange(int(length * RATE)) / RATE
    x = 0.0005 * rng.standard_normal(len(t))
    hum = (t >= 0.015) & (t < burst_at)
    x[hum] += 0.03 * np.sin(2 * np.pi * 110 * t[hum])
    b0, b1 = int(burst_at * RATE), int((burst_at + 0.01) * RATE)
    x[b0:b1] += 0.2 * rng.standard_normal(b1 - b0)
    vowel = t >= burst_at + 0.01
    x[vowel] += sum(0.1 / k * np.sin(2 * np.pi * 120 * k * t[vowel]) for k in range(1, 25))
    return Audio(x.astype(np.float32), RATE)


def test_burst_found_after_prevoicing():
    snd = _prevoiced_stop(0.065)
    t = burst_time(snd, 0.0, 0.1)
    assert t is not None and abs(t - 0.065) <= 0.004


def test_no_burst_in_a_steady_vowel():
    snd = _prevoiced_stop(0.065)
    assert burst_time(snd, 0.12, 0.25) is None


def test_clip_initial_stop_moves_to_its_burst():
    snd = _prevoiced_stop(0.065)
    result = [[("B", 0.0, 0.08), ("AA", 0.08, 0.25)]]
    refine_stops(snd, result, [False])
    assert abs(result[0][0][1] - 0.065) <= 0.004
    assert result[0][0][2] == 0.08 and result[0][1] == ("AA", 0.08, 0.25)


def test_stop_inside_speech_and_estimated_words_are_left_alone():
    snd = _prevoiced_stop(0.065)
    # A stop right after another word keeps its closure.
    result = [[("AH", 0.0, 0.02)], [("B", 0.02, 0.08), ("AA", 0.08, 0.25)]]
    refine_stops(snd, result, [False, False])
    assert result[1][0] == ("B", 0.02, 0.08)
    # Placed by estimate: no acoustic evidence to refine.
    result = [[("B", 0.0, 0.08), ("AA", 0.08, 0.25)]]
    refine_stops(snd, result, [True])
    assert result[0][0] == ("B", 0.0, 0.08)
