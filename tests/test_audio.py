"""Resampling to the aligner's 16 kHz, and plain PCM WAV files read without Praat."""

import numpy as np
import pytest

from addon.engine import audio, resampling


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
    whole = resampling._resample_whole(x, 44100, 16000)
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


@pytest.mark.parametrize("rate", [44100, 48000, 22050, 8000, 16000])
def test_a_stream_of_pieces_resamples_as_the_whole_signal(rate):
    """Decoded blocks of any size, pushed as they come, give the samples
    resample gives for the whole signal."""
    rng = np.random.default_rng(rate)
    x = (rng.normal(size=int(rate * 14.3)) * 0.1).astype(np.float32)
    stream, out, i = resampling.StreamResampler(rate), [], 0
    while i < len(x):
        k = int(rng.integers(1, 90000))
        out.append(stream.push(x[i:i + k]))
        i += k
    out.append(stream.finish())
    assert np.array_equal(np.concatenate(out), resampling.resample(x, rate))


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
    samples, read_rate, cut = wavstream.read_wav(path)
    assert read_rate == rate and not cut and not isinstance(samples, wavstream.WavSamples)
    assert np.array_equal(audio.from_samples(samples, rate).samples, expected)
    assert np.array_equal(audio.load(path).samples, expected)


@pytest.mark.parametrize("rate,width,channels", [(44100, 2, 2), (16000, 3, 1), (22050, 1, 1)])
def test_long_wav_read_block_by_block_gives_praats_samples(tmp_path, rate, width, channels):
    """A long WAV file is read a block at a time (bounded memory), with the
    samples Praat's reader gives; so is a long file cut short, whose missing
    end is silence (as in Praat), with a note saying so."""
    import parselmouth

    from addon.engine import wavstream

    path = write_pcm(tmp_path, rate, width, channels, wavstream.LONG + 1)
    streamed, read_rate, cut_short = wavstream.read_wav(path)
    assert isinstance(streamed, wavstream.WavSamples) and read_rate == 16000 and not cut_short
    praat = parselmouth.Sound(str(path))
    expected = audio.from_samples(praat.values, praat.sampling_frequency).samples
    assert np.array_equal(audio.load(path).samples, expected)
    assert np.array_equal(streamed[0:len(streamed)], expected)
    raw = path.read_bytes()
    cut = tmp_path / "cut.wav"
    cut.write_bytes(raw[:44 + (len(raw) // 3 // width // channels * channels + 1) * width])  # inside a frame
    snd = audio.load(cut)
    assert isinstance(snd.samples, wavstream.WavSamples)
    assert "cut short" in " ".join(snd.notes)
    praat = parselmouth.Sound(str(cut))
    expected = audio.from_samples(praat.values, praat.sampling_frequency).samples
    assert len(snd.samples) == len(expected)
    assert np.abs(snd.samples[0:len(snd.samples)] - expected).max() < 1e-6


@pytest.mark.parametrize("width", [1, 2, 3])
def test_short_wav_cut_short_reads_as_praat_reads_it(tmp_path, width):
    """The frames a WAV file cut short holds, then silence up to the length
    its header gives (as Praat reads it), with a note; no Praat needed."""
    import parselmouth

    from addon.engine import wavstream

    raw = write_pcm(tmp_path, 22050, width, 2, 3.0).read_bytes()
    cut = tmp_path / "cut.wav"
    cut.write_bytes(raw[:44 + (len(raw) // 4 // width // 2 * 2 + 1) * width])   # inside a frame
    samples, rate, cut_short = wavstream.read_wav(cut)
    assert cut_short and rate == 22050 and len(samples) == 3 * 22050
    assert np.all(samples[-22050 // 5:] == 0)
    snd = audio.load(cut)
    assert any(str(cut) in n and "cut short" in n for n in snd.notes)
    praat = parselmouth.Sound(str(cut))
    assert np.array_equal(snd.samples, audio.from_samples(praat.values, praat.sampling_frequency).samples)


def test_levels_and_band_changes_read_a_streamed_long_wav_as_in_memory(tmp_path):
    """The checks of a take (speech-band levels) and the boundary model read a long WAV file a block
    at a time, by slices: the same figures as from the samples in memory (an index raised TypeError)."""
    from addon.engine import wavstream
    from addon.engine.alignment import refine
    from addon.engine.alignment.speech import frame_levels

    snd = audio.load(write_pcm(tmp_path, 16000, 2, 1, wavstream.LONG + 1))
    assert isinstance(snd.samples, wavstream.WavSamples)
    whole = audio.Audio(np.asarray(snd.samples), snd.rate)
    for emphasis in (False, True):
        assert np.array_equal(frame_levels(snd, emphasis=emphasis), frame_levels(whole, emphasis=emphasis))
    doc = refine.model()
    assert np.array_equal(refine.band_changes(snd, doc), refine.band_changes(whole, doc))
