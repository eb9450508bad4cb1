"""Resampling to the aligner's 16 kHz."""

import numpy as np
import pytest

from addon.engine import audio


@pytest.mark.parametrize("rate", [44100, 48000, 22050, 8000])
def test_resampled_sine_keeps_its_frequency_and_level(rate):
    t = np.arange(int(rate * 20.3)) / rate          # long enough to go block by block
    x = 0.5 * np.sin(2 * np.pi * 440.0 * t)
    y = audio.resample(x, rate)
    assert len(y) == round(len(x) * 16000 / rate)
    t_out = np.arange(len(y)) / 16000
    inner = slice(1600, len(y) - 1600)               # the clip's ends ring a little
    assert np.abs(y[inner] - 0.5 * np.sin(2 * np.pi * 440.0 * t_out[inner])).max() < 2e-3


def test_blocks_match_the_whole_signal_transform():
    rng = np.random.default_rng(0)
    x = rng.normal(size=44100 * 12) * 0.1
    blocked = audio.resample(x, 44100)
    whole = audio._resample_whole(x, 44100, 16000)
    assert np.sqrt(np.mean((blocked - whole) ** 2)) < 0.01 * np.sqrt(np.mean(whole ** 2))   # -40 dB
    assert np.abs(blocked - whole).max() < 0.01


def test_speech_band_survives_and_aliases_do_not():
    rate = 44100
    t = np.arange(rate * 8) / rate
    x = np.sin(2 * np.pi * 1000 * t) + np.sin(2 * np.pi * 12000 * t)   # 12 kHz is above the new Nyquist
    y = audio.resample(x, rate)
    spec = np.abs(np.fft.rfft(y[16000:-16000]))
    freqs = np.fft.rfftfreq(len(y) - 32000, 1 / 16000)
    assert freqs[np.argmax(spec)] == pytest.approx(1000, abs=2)
    alias = spec[np.abs(freqs - 4000) < 20].max()                       # 12 kHz would fold to 4 kHz
    assert alias < 1e-2 * spec.max()


def write_pcm(tmp_path, rate, width, channels, seconds, name="long.wav"):
    """A plain PCM WAV file of a sine at varying level per channel."""
    import wave

    n = int(rate * seconds)
    rng = np.random.default_rng(rate)
    x = np.sin(np.arange(n) * 0.03)[:, None] * rng.uniform(0.1, 0.9, (n, channels))
    if width == 1:
        data = (x * 127 + 128).astype(np.uint8).tobytes()
    elif width == 3:
        data = (x * 8388607).astype("<i4").view(np.uint8).reshape(-1, 4)[:, :3].tobytes()
    else:
        data = (x * 32767).astype("<i2").tobytes()
    with wave.open(str(tmp_path / name), "wb") as w:
        w.setnchannels(channels), w.setsampwidth(width), w.setframerate(rate)
        w.writeframes(data)
    return tmp_path / name


@pytest.mark.parametrize("rate,width,channels", [(44100, 2, 2), (16000, 3, 1), (22050, 1, 1), (16000, 2, 1)])
def test_short_wav_read_without_praat_gives_praats_samples(tmp_path, rate, width, channels):
    import parselmouth

    from addon.engine import wavstream

    path = write_pcm(tmp_path, rate, width, channels, 3.5, "short.wav")
    praat = parselmouth.Sound(str(path))
    expected = audio.from_samples(praat.values, praat.sampling_frequency).samples
    read = wavstream.read_wav(path)
    assert read is not None and not isinstance(read.samples, wavstream.WavSamples)
    assert np.array_equal(read.samples, expected)
    assert np.array_equal(audio.load(path).samples, expected)


@pytest.mark.parametrize("rate,width,channels", [(44100, 2, 2), (16000, 3, 1), (22050, 1, 1)])
def test_long_wav_read_block_by_block_gives_praats_samples(tmp_path, rate, width, channels):
    """A long WAV file is read a block at a time (bounded memory), with the
    samples Praat's reader gives; a long file cut short is left to Praat,
    which says so."""
    import parselmouth

    from addon.engine import wavstream

    path = write_pcm(tmp_path, rate, width, channels, wavstream.LONG + 1)
    streamed = wavstream.read_wav(path)
    assert streamed is not None
    praat = parselmouth.Sound(str(path))
    expected = audio.from_samples(praat.values, praat.sampling_frequency).samples
    assert np.array_equal(audio.load(path).samples, expected)
    assert np.array_equal(streamed.samples, expected)
    raw = path.read_bytes()
    cut = tmp_path / "cut.wav"
    cut.write_bytes(raw[:len(raw) * 2 // 3])
    assert wavstream.read_wav(cut) is None
    assert "cut short" in " ".join(audio.load(cut).notes)
