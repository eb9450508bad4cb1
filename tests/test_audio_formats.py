"""The engine's one audio reader on every format it reads: WAV (8-32-bit
integer and float, any rate, any channel count), FLAC, AIFF, Ogg Vorbis,
Ogg Opus, MP3, M4A (AAC) and the sound track of MP4, MOV and MKV video.

Each file is made at test time from the sample line (hello.wav, with
hello.txt), with soundfile (libsndfile) or av (FFmpeg), the decoders the
engine itself uses (requirements.txt), and aligned: every phone boundary
lies within 10 ms of the WAV's alignment, and lossless files of the line's
own rate align exactly as hello.wav does.  (The aligner hears every clip
over a fixed noise floor, :data:`addon.engine.audio.FLOOR_DB`; without it a
lossy codec's rounding in a pause moved boundaries by up to 0.2 s.)
"""

from __future__ import annotations

import json
import pickle
import subprocess
import sys
import wave
from pathlib import Path

import numpy as np
import pytest

from addon.engine import audio, decoders, wavstream
from addon.engine.errors import AudioError
from addon.engine.resampling import resample

ROOT = Path(__file__).resolve().parent.parent
HELLO = ROOT / "sample_rigs" / "speech" / "hello.wav"
TEXT = HELLO.with_suffix(".txt").read_text(encoding="utf-8")
RATE = 22050   # hello.wav's


def hello() -> np.ndarray:
    with wave.open(str(HELLO)) as w:
        assert w.getframerate() == RATE and w.getnchannels() == 1 and w.getsampwidth() == 2
        return np.frombuffer(w.readframes(w.getnframes()), "<i2").astype(np.float32) / 32768.0


def channels(x: np.ndarray, n: int) -> np.ndarray:
    """(samples, n): the line on every channel, each at its own level."""
    return np.stack([x * (1.0 - 0.15 * c) for c in range(n)], axis=1)


def write_sf(path, x, rate, n, fmt, subtype):
    import soundfile

    y = channels(x if rate == RATE else resample(x, RATE, rate), n)
    with soundfile.SoundFile(str(path), "w", rate, n, subtype, format=fmt) as f:
        for i in range(0, len(y), 1 << 15):     # libsndfile's Vorbis encoder crashes on one long write
            f.write(y[i:i + (1 << 15)])


def write_av(path, x, rate, n, container, video=False):
    """AAC in ``container``, with a small video track if ``video``."""
    import av

    y = x if rate == RATE else resample(x, RATE, rate)
    data = np.ascontiguousarray(channels(y, n).T.astype(np.float32))
    layout = {1: "mono", 2: "stereo"}[n]
    with av.open(str(path), "w", format=container) as c:
        if video:
            vs = c.add_stream("mpeg4", rate=24)
            vs.width, vs.height, vs.pix_fmt = 64, 48, "yuv420p"
        s = c.add_stream("aac", rate=rate, layout=layout)
        shown = 0
        for i in range(0, data.shape[1], 1024):
            frame = av.AudioFrame.from_ndarray(data[:, i:i + 1024], format="fltp", layout=layout)
            frame.sample_rate, frame.pts = rate, i
            for packet in s.encode(frame):
                c.mux(packet)
            while video and shown / 24 <= (i + 1024) / rate:
                picture = av.VideoFrame.from_ndarray(np.full((48, 64, 3), shown % 255, np.uint8), format="rgb24")
                picture.pts = shown
                shown += 1
                for packet in vs.encode(picture):
                    c.mux(packet)
        for packet in s.encode(None):
            c.mux(packet)
        if video:
            for packet in vs.encode(None):
                c.mux(packet)


#: name -> (file name, how it is written, the line's very samples (lossless, mono, its rate), the
#: independent decoder).  Other channels carry the line at lower levels.
CASES = {
    "wav-8bit": ("line.wav", lambda p, x: write_sf(p, x, RATE, 1, "WAV", "PCM_U8"), False, "av"),
    "wav-16bit-44k-stereo": ("line.wav", lambda p, x: write_sf(p, x, 44100, 2, "WAV", "PCM_16"), False, "av"),
    "wav-24bit-48k-6ch": ("line.wav", lambda p, x: write_sf(p, x, 48000, 6, "WAVEX", "PCM_24"), False, "av"),
    "wav-32bit": ("line.wav", lambda p, x: write_sf(p, x, RATE, 1, "WAV", "PCM_32"), True, "av"),
    "wav-float": ("line.wav", lambda p, x: write_sf(p, x, RATE, 1, "WAV", "FLOAT"), True, "av"),
    "wav-double-96k": ("line.wav", lambda p, x: write_sf(p, x, 96000, 1, "WAV", "DOUBLE"), False, "av"),
    "flac": ("line.flac", lambda p, x: write_sf(p, x, RATE, 1, "FLAC", "PCM_24"), True, "av"),
    "flac-stereo-48k": ("line.flac", lambda p, x: write_sf(p, x, 48000, 2, "FLAC", "PCM_16"), False, "av"),
    "aiff": ("line.aiff", lambda p, x: write_sf(p, x, RATE, 1, "AIFF", "PCM_16"), True, "av"),
    "ogg-vorbis": ("line.ogg", lambda p, x: write_sf(p, x, 44100, 2, "OGG", "VORBIS"), False, "av"),
    "ogg-opus": ("line.opus", lambda p, x: write_sf(p, x, 48000, 1, "OGG", "OPUS"), False, "soundfile"),
    "mp3": ("line.mp3", lambda p, x: write_sf(p, x, RATE, 1, "MP3", "MPEG_LAYER_III"), False, "soundfile"),
    "m4a-aac": ("line.m4a", lambda p, x: write_av(p, x, RATE, 1, "ipod"), False, "av"),
    "mp4-video": ("line.mp4", lambda p, x: write_av(p, x, 48000, 2, "mp4", video=True), False, "av"),
    "mov-video": ("line.mov", lambda p, x: write_av(p, x, 44100, 2, "mov", video=True), False, "av"),
    "mkv-video": ("line.mkv", lambda p, x: write_av(p, x, 48000, 2, "matroska", video=True), False, "av"),
}


def make(tmp_path, case) -> Path:
    name, write, _, _ = CASES[case]
    path = tmp_path / name
    write(path, hello())
    return path


def independent_decode(path, package) -> tuple[np.ndarray, int]:
    """The file decoded whole by ``package`` alone, channels averaged."""
    if package == "soundfile":
        import soundfile

        x, rate = soundfile.read(str(path), dtype="float32", always_2d=True)
        return x.mean(axis=1), rate
    import av

    parts, to_float = [], None
    with av.open(str(path)) as c:
        for frame in c.decode(c.streams.audio[0]):
            rate = frame.sample_rate
            to_float = to_float or av.AudioResampler(format="fltp", layout=frame.layout, rate=rate)
            parts += [f.to_ndarray().mean(axis=0) for f in to_float.resample(frame)]
    return np.concatenate(parts), rate


def boundaries(result) -> np.ndarray:
    return np.array([[p.start, p.end] for p in result.alignment.phones]).ravel()


@pytest.fixture(scope="module")
def original():
    from addon.engine.pipeline import analyze

    return audio.load(HELLO), analyze(str(HELLO), TEXT)


def lag_and_likeness(a: np.ndarray, b: np.ndarray, most: int = 400) -> tuple[int, float]:
    """The shift (samples) that best lines ``a`` up with ``b`` (within
    ``most``), and their correlation there."""
    n = min(len(a), len(b))
    a, b = a[:n].astype(np.float64), b[:n].astype(np.float64)
    size = 1 << (2 * n - 1).bit_length()
    c = np.fft.irfft(np.fft.rfft(a, size) * np.conj(np.fft.rfft(b, size)), size)
    c = np.concatenate([c[-most:], c[:most + 1]])
    lag = int(np.argmax(c)) - most
    return lag, float(c.max() / np.sqrt((a ** 2).sum() * (b ** 2).sum()))


@pytest.mark.parametrize("case", CASES)
def test_the_same_line_in_every_format_gives_the_same_alignment(tmp_path, original, case):
    from addon.engine.pipeline import analyze

    ref_audio, ref_result = original
    path = make(tmp_path, case)
    snd = audio.load(path)
    # The same sound at the same time: no decoder delay, no drift, nothing lost (an AAC file ends on a
    # whole frame of 1024 samples: up to 46 ms of padding at 22.05 kHz).
    assert snd.rate == 16000
    assert -0.001 < snd.duration - ref_audio.duration < 0.05, (snd.duration, ref_audio.duration)
    lag, likeness = lag_and_likeness(np.asarray(snd.samples), ref_audio.samples)
    assert lag == 0 and likeness > 0.97, (lag, likeness)

    result = analyze(str(path), TEXT)
    assert [w.text for w in result.alignment.words] == [w.text for w in ref_result.alignment.words]
    # Every phone boundary within 20 ms of the WAV's (a 10 ms frame, and the ms the boundary model's
    # correction follows the sound by: a lossy codec's cut of the highest band moves it); lossless at
    # the line's own rate, the very same.
    moved = np.abs(boundaries(result) - boundaries(ref_result))
    assert moved.max() <= 0.0201, (moved.max(), np.mean(moved > 0.0201))
    if CASES[case][2]:
        assert moved.max() == 0.0


@pytest.mark.parametrize("case", ["ogg-vorbis", "m4a-aac"])
def test_long_files_are_decoded_block_by_block_into_a_temporary_file(tmp_path, case):
    """A file longer than a minute is resampled as it is decoded and kept on
    disk, with the samples a whole decode and resample would give; pickled
    (to a worker process) it travels as the array."""
    x = np.tile(hello(), 11)[:int(RATE * (wavstream.LONG + 2))]
    path = tmp_path / CASES[case][0]
    CASES[case][1](path, x)
    snd = audio.load(path)
    assert isinstance(snd.samples, decoders.DiskSamples) and snd.rate == 16000
    whole, rate = independent_decode(path, "soundfile" if case == "ogg-vorbis" else "av")
    expected = resample(whole, rate)
    assert len(snd.samples) == len(expected)
    assert np.abs(snd.samples[0:len(expected)] - expected).max() < 1e-5
    start = 16000 * 50
    assert np.array_equal(snd.samples[start:start + 1600], snd.samples[0:len(expected)][start:start + 1600])
    copy = pickle.loads(pickle.dumps(snd))
    assert isinstance(copy.samples, np.ndarray) and np.array_equal(copy.samples, np.asarray(snd.samples))


def test_a_batch_manifest_mixing_formats_runs_through(tmp_path):
    """One manifest, the line in six formats: every line lip-synced, the
    same words, nothing on stderr but the run's own report."""
    cases = ["ogg-vorbis", "ogg-opus", "mp3", "m4a-aac", "flac", "wav-24bit-48k-6ch", "mkv-video"]
    rows = ["audio,transcript"]
    (tmp_path / "hello.txt").write_text(TEXT, encoding="utf-8")
    for case in cases:
        folder = tmp_path / case
        folder.mkdir()
        path = make(folder, case)
        rows.append(f"{path.relative_to(tmp_path)},hello.txt")
    (tmp_path / "lines.csv").write_text("\n".join(rows) + "\n")
    r = subprocess.run([sys.executable, "-m", "addon", "batch", str(tmp_path / "lines.csv"), "--json",
                        "--workers", "2"], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert "Traceback" not in r.stderr and "error" not in r.stderr.lower() and "[src/" not in r.stderr, r.stderr
    for case in cases:
        out = next((tmp_path / case).glob("line.json"))
        words = [w["word"] for w in json.loads(out.read_text())["words"]]
        assert words[:3] == ["hello", "my", "name"] and words[-1] == "voice", (case, words)


@pytest.mark.parametrize("name,head,what", [
    ("line.ogg", b"OggS\x00\x02" + bytes(60), "an Ogg file (Vorbis or Opus)"),
    ("line.flac", b"fLaC" + bytes(60), "a FLAC file"),
    ("line.mp3", b"ID3\x04\x00\x00\x00\x00\x00\x00" + bytes(60), "an MP3 file"),
    ("line.aiff", b"FORM\x00\x00\x00\x40AIFF" + bytes(60), "an AIFF file"),
    ("line.m4a", b"\x00\x00\x00\x20ftypM4A " + bytes(60), "an MP4/M4A/MOV file"),
    ("line.mkv", b"\x1aE\xdf\xa3" + bytes(60), "a Matroska/WebM file"),
    ("line.wav", b"RIFF\x20\x00\x00\x00WAVEfmt " + bytes(60), "a WAV file"),
])
def test_a_file_that_cannot_be_decoded_is_one_line_naming_the_file_and_what_it_is(tmp_path, name, head, what):
    path = tmp_path / name
    path.write_bytes(head + np.random.default_rng(0).bytes(3000))
    with pytest.raises(AudioError) as err:
        audio.load(path)
    msg = str(err.value)
    assert "\n" not in msg and str(path) in msg and f"it is {what}" in msg and "cannot be decoded" in msg


def test_a_file_cut_short_is_read_up_to_where_it_breaks_with_a_warning(tmp_path):
    """A FLAC file cut in the middle (a download that stopped): the sound up
    to the cut, and a note (shown as a warning) naming the file and where its
    sound ends."""
    whole = make(tmp_path, "flac")
    raw = whole.read_bytes()
    cut = tmp_path / "cut.flac"
    cut.write_bytes(raw[:len(raw) * 6 // 10])
    snd = audio.load(cut)
    full = audio.load(whole)
    assert 0.45 * full.duration < snd.duration < 0.62 * full.duration
    assert np.abs(snd.samples[:16000] - full.samples[:16000]).max() < 1e-3    # resampled at another length
    (note,) = snd.notes
    assert str(cut) in note and "cut short" in note and f"up to {snd.duration:.2f} s" in note
    assert audio.load(whole).notes == []


def test_a_video_without_sound_says_so(tmp_path):
    import av

    path = tmp_path / "silent.mp4"
    with av.open(str(path), "w") as c:
        vs = c.add_stream("mpeg4", rate=24)
        vs.width, vs.height, vs.pix_fmt = 64, 48, "yuv420p"
        for i in range(24):
            picture = av.VideoFrame.from_ndarray(np.zeros((48, 64, 3), np.uint8), format="rgb24")
            picture.pts = i
            for packet in vs.encode(picture):
                c.mux(packet)
        for packet in vs.encode(None):
            c.mux(packet)
    with pytest.raises(AudioError, match=r"silent\.mp4: it is an MP4/M4A/MOV file, but .*holds no sound track"):
        audio.load(path)


def test_without_the_decoders_the_reader_says_which_package_a_file_needs(tmp_path, monkeypatch):
    """Where neither package is installed (the Blender extension bundles
    neither), WAV, FLAC, MP3 and AIFF are read by Praat, and an Ogg or M4A
    file gets a message naming the package it needs."""
    ogg, m4a, flac = make(tmp_path, "ogg-vorbis"), make(tmp_path, "m4a-aac"), make(tmp_path, "flac")
    with_decoders = audio.load(flac).samples
    monkeypatch.setitem(sys.modules, "soundfile", None)
    monkeypatch.setitem(sys.modules, "av", None)
    with pytest.raises(AudioError, match=r"line\.ogg: it is an Ogg Vorbis file; .*needs the Python package soundfile "
                                         r"\(pip install soundfile\)"):
        audio.load(ogg)
    with pytest.raises(AudioError, match=r"line\.m4a: it is an MP4/M4A/MOV file; .*\(pip install av\)"):
        audio.load(m4a)
    assert np.abs(audio.load(flac).samples - with_decoders).max() < 1e-4


def test_the_decoders_are_imported_only_when_a_file_needs_them():
    """The engine (and so the Blender extension, which does not bundle them)
    loads neither package until a file in their formats is read."""
    code = ("import sys; from addon.engine import pipeline, batch, arousal, audio; "
            f"audio.load({str(HELLO)!r}); print('soundfile' in sys.modules, 'av' in sys.modules)")
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert r.stdout.split() == ["False", "False"], r.stderr


@pytest.mark.parametrize("noise_db", [-90, -70])
def test_pauses_of_digital_silence_or_of_quiet_noise_align_alike(original, noise_db):
    """hello.wav's pauses are exact digital silence; filled with white noise
    (a room's, a codec's rounding), its phones keep their boundaries within
    10 ms, and a noise gate that zeroes every frame 45 dB under the loud ones
    changes nothing."""
    from addon.engine.pipeline import analyze

    _, ref_result = original
    x = hello()
    noisy = x + np.random.default_rng(1).standard_normal(len(x)).astype(np.float32) * 10 ** (noise_db / 20)
    moved = np.abs(boundaries(analyze(audio.from_samples(noisy, RATE), TEXT)) - boundaries(ref_result))
    assert moved.max() <= 0.0101, moved.max()
    frame = RATE // 100
    n = len(noisy) // frame * frame
    rms = np.sqrt((noisy[:n].reshape(-1, frame) ** 2).mean(axis=1))
    gated = noisy.copy()
    gated[:n] *= np.repeat(rms > np.percentile(rms, 95) * 10 ** (-45 / 20), frame)
    assert np.sum(gated == 0) > 0.2 * len(x)
    moved = np.abs(boundaries(analyze(audio.from_samples(gated, RATE), TEXT)) - boundaries(ref_result))
    assert moved.max() <= 0.0101, moved.max()


def test_the_floor_under_the_aligner_is_the_same_wherever_a_clip_is_cut_and_follows_its_level():
    line = audio.load(HELLO).samples
    snd = audio.Audio(np.concatenate([np.zeros(8000, np.float32), line]), 16000)    # 0.5 s of digital silence first
    whole = np.frombuffer(snd.pcm16(), "<i2")
    assert np.array_equal(np.frombuffer(snd.pcm16(1.0, 2.5), "<i2"), whole[16000:40000])
    floor = whole[:8000].astype(float).std()
    expected = snd.loud_level() * 10 ** (audio.FLOOR_DB / 20) * 32767
    assert 0.9 * expected < floor < 1.1 * expected and floor > 10
    quiet = audio.Audio(snd.samples * 0.1, snd.rate)
    assert np.abs(np.frombuffer(quiet.pcm16(), "<i2") - 0.1 * whole).max() <= 1.5
    # Recognition hears the samples as they are.
    assert not np.frombuffer(snd.pcm16(0.0, 0.5, floor=False), "<i2").any()
