import numpy as np
import pytest

from addon.engine import prosody
from addon.engine.prosody import ClipStats, Tracks
from addon.engine.weights import phoneme_weights, piecewise

STATS = ClipStats(f_min=100, f_mean=150, f_max=250, i_min=40, i_mean=60, i_max=80, voiced=True)
RANGE = np.array([[0.2, 0.6, 1.0]])


def test_equation_1_by_hand():
    # Above the mean: W_p + (F - F_mean) * (W_max - W_p) / (F_max - F_mean)
    assert piecewise(200, 100, 150, 250, 0.2, 0.6, 1.0) == pytest.approx(0.6 + 50 * 0.4 / 100)   # 0.8
    # Below the mean: W_min + (F - F_min) * (W_p - W_min) / (F_mean - F_min)
    assert piecewise(125, 100, 150, 250, 0.2, 0.6, 1.0) == pytest.approx(0.2 + 25 * 0.4 / 50)    # 0.4
    assert piecewise(150, 100, 150, 250, 0.2, 0.6, 1.0) == pytest.approx(0.6)
    # Outside the clip's range: clamped to W_min / W_max.
    assert piecewise([50, 400], 100, 150, 250, 0.2, 0.6, 1.0) == pytest.approx([0.2, 1.0])


def test_flat_clip_does_not_divide_by_zero():
    assert piecewise([150, 150], 150, 150, 150, 0.2, 0.6, 1.0) == pytest.approx([0.6, 0.6])
    assert piecewise(np.nan, 100, 150, 250, 0.2, 0.6, 1.0) == pytest.approx(0.6)


def test_vowel_averages_pitch_and_intensity_plosive_uses_pitch():
    # Pitch 200 -> W_F = 0.8; intensity 50 -> W_I = 0.2 + 10 * 0.4 / 20 = 0.4.
    w = phoneme_weights(["AA", "P", "M"], np.array([200.0] * 3), np.array([50.0] * 3), STATS,
                        np.repeat(RANGE, 3, axis=0), other_source="intensity")
    assert w == pytest.approx([0.6, 0.8, 0.4])
    w = phoneme_weights(["M"], np.array([200.0]), np.array([50.0]), STATS, RANGE, other_source="neutral")
    assert w == pytest.approx([0.6])


def test_silent_clip_stats_and_weights():
    n = 100
    tracks = Tracks(np.arange(n) * 0.01, np.full(n, np.nan), np.full(n, -300.0))
    stats = prosody.clip_stats(tracks)
    assert not stats.voiced
    pitch, inten = prosody.phoneme_means(tracks, [(0.1, 0.2), (0.5, 0.6)], stats)
    w = phoneme_weights(["AA", "S"], pitch, inten, stats, np.repeat(RANGE, 2, axis=0))
    assert np.isfinite(w).all() and ((0 <= w) & (w <= 1)).all()
    assert w[1] == pytest.approx(0.6)   # no pitch: neutral weight


def test_flat_tone_has_finite_weights():
    from addon.engine.audio import Audio
    t = np.arange(16000) / 16000
    tone = Audio((0.3 * np.sin(2 * np.pi * 150 * t)).astype(np.float32), 16000)
    tracks = prosody.analyse(tone)
    stats = prosody.clip_stats(tracks)
    assert stats.voiced and stats.f_mean == pytest.approx(150, abs=3)
    pitch, inten = prosody.phoneme_means(tracks, [(0.2, 0.4)], stats)
    w = phoneme_weights(["AA"], pitch, inten, stats, RANGE)
    assert np.isfinite(w).all()


def test_manual_pitch_range():
    n = 50
    tracks = Tracks(np.arange(n) * 0.01, np.full(n, 120.0), np.full(n, 60.0))
    male = prosody.clip_stats(tracks, pitch_range="male")
    assert (male.f_min, male.f_max) == (85.0, 180.0)
    female = prosody.clip_stats(tracks, pitch_range="female")
    assert female.f_min == 165.0 and female.f_mean == 165.0  # clamped into the range
    custom = prosody.clip_stats(tracks, pitch_range=(100, 300))
    assert (custom.f_min, custom.f_max) == (100.0, 300.0)


def test_long_clip_prosody_in_pieces_matches_the_whole(monkeypatch):
    """Long clips are analysed in pieces (bounded memory); pitch and
    intensity agree with one analysis of the whole clip."""
    from addon.engine import audio, prosody

    rate = 16000
    t = np.arange(rate * 21) / rate
    f0 = 120 + 40 * np.sin(2 * np.pi * t / 7)                   # a gliding voice
    x = 0.3 * np.sign(np.sin(2 * np.pi * np.cumsum(f0) / rate)) * (np.sin(2 * np.pi * t / 3) > -0.3)
    snd = audio.Audio(x.astype(np.float32), rate)
    whole = prosody.analyse(snd)
    monkeypatch.setattr(prosody, "PIECE", 4.0)
    pieces = prosody.analyse(snd)
    assert np.array_equal(pieces.times, whole.times)
    both = np.isfinite(whole.pitch) & np.isfinite(pieces.pitch)
    assert np.mean(np.isfinite(whole.pitch) == np.isfinite(pieces.pitch)) > 0.98 and both.mean() > 0.5
    assert np.median(np.abs(pieces.pitch[both] / whole.pitch[both] - 1)) < 0.01
    assert np.median(np.abs(pieces.intensity - whole.intensity)) < 0.5
