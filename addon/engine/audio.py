"""Audio in: any file Praat can read (WAV, FLAC, MP3, AIFF, ...) or samples
handed over by a host program (Blender decodes its own sound strips), reduced
to 16 kHz mono, the rate of the acoustic model."""

from __future__ import annotations

import math
import os
import warnings
from dataclasses import dataclass, field

import numpy as np

from .errors import AudioError

MODEL_RATE = 16000


@dataclass
class Audio:
    samples: np.ndarray  # float32, mono, in [-1, 1]
    rate: int
    #: What the reader had to repair (a file cut short ...): shown to the user as warnings.
    notes: list = field(default_factory=list)

    @property
    def duration(self) -> float:
        return len(self.samples) / self.rate

    def pcm16(self, start: float = 0.0, end: float | None = None) -> bytes:
        a = int(round(start * self.rate))
        b = len(self.samples) if end is None else int(round(end * self.rate))
        clip = np.clip(self.samples[a:b], -1.0, 1.0)
        return (clip * 32767.0).astype("<i2").tobytes()


def _fast_length(n: int) -> int:
    """Smallest 2^a 3^b 5^c >= n, a length the FFT handles quickly."""
    best = 1 << (n - 1).bit_length()
    p5 = 1
    while p5 < best:
        p35 = p5
        while p35 < best:
            p = p35
            while p < n:
                p *= 2
            best = min(best, p)
            p35 *= 3
        p5 *= 5
    return best


def _resample_whole(samples: np.ndarray, rate: float, target: int) -> np.ndarray:
    n = len(samples)
    n_out = int(round(n * target / rate))
    if float(rate) == int(rate):
        # Both padded lengths whole multiples of the rates' ratio: the new
        # grid is exactly the old one rescaled, with no drift along the clip.
        g = math.gcd(int(rate), target)
        down, up = int(rate) // g, target // g
        m = _fast_length(-(-(n + int(rate // 10)) // down))
        pad, pad_out = down * m, up * m
    else:
        pad = _fast_length(n + int(rate // 10))
        pad_out = int(round(pad * target / rate))
    spec = np.fft.rfft(samples, pad)
    keep = pad_out // 2 + 1
    if keep <= len(spec):
        spec = spec[:keep]
    else:
        spec = np.concatenate([spec, np.zeros(keep - len(spec), spec.dtype)])
    out = np.fft.irfft(spec, pad_out) * (pad_out / pad)
    return out[:n_out]


#: Blocks for long signals: FFTs of ~2^17 samples stay in cache, and the
#: margins (discarded) keep each block's edges away from the output.
_BLOCK = 1 << 17
_MARGIN = 4096


def resample(samples: np.ndarray, rate: float, target: int = MODEL_RATE) -> np.ndarray:
    """Band-limited resampling by FFT (the spectrum is cut at the new Nyquist
    frequency).  Zero padding to a fast length avoids slow prime-length FFTs
    and wrap-around at the ends.  Long signals at an integer rate go block by
    block, each block cut on a sample both rates share, with overlapping
    margins thrown away: the same result, several times faster."""
    samples = np.asarray(samples)
    if samples.dtype != np.float32:
        samples = samples.astype(np.float64)
    if int(round(rate)) == target:
        return samples.astype(np.float32)
    n = len(samples)
    if n == 0:
        return np.zeros(0, np.float32)
    if n <= 2 * _BLOCK or float(rate) != int(rate):
        return _resample_whole(samples.astype(np.float64), rate, target).astype(np.float32)
    # Converted to 64 bits a block at a time: no 64-bit copy of a long signal.
    return resample_blocks(lambda a, b: samples[a:b].astype(np.float64), n, int(rate), target)


def resample_blocks(read, n: int, rate: int, target: int = MODEL_RATE) -> np.ndarray:
    """:func:`resample` of a long signal of ``n`` samples at an integer
    rate, read block by block: ``read(a, b)`` returns samples a..b as
    float64 (a file can be read a piece at a time)."""
    blocks = BlockResampler(read, n, rate, target)
    out = np.empty(blocks.n_out, np.float32)
    for j in range(blocks.n_blocks):
        o0 = j * blocks.per_block
        y = blocks.block(j)
        out[o0:o0 + len(y)] = y
    return out


class BlockResampler:
    """The blocks :func:`resample` cuts a long signal at an integer rate
    into: block ``j`` of the output (``per_block`` samples, the last one
    shorter) from the input samples ``read(a, b)`` returns (float64)."""

    def __init__(self, read, n: int, rate: int, target: int = MODEL_RATE):
        g = math.gcd(int(rate), target)
        self.read, self.n, self.rate, self.target = read, n, int(rate), target
        self.down, self.up = int(rate) // g, target // g     # 441 input samples -> 160 output samples
        self.step = self.down * max(1, _BLOCK // self.down)
        self.margin = self.down * -(-_MARGIN // self.down)
        self.n_out = int(round(n * target / rate))
        self.per_block = self.step // self.down * self.up
        self.n_blocks = -(-n // self.step)

    def block(self, j: int) -> np.ndarray:
        start = j * self.step
        a, b = max(0, start - self.margin), min(self.n, start + self.step + self.margin)
        y = _resample_whole(self.read(a, b), self.rate, self.target)
        o0 = start // self.down * self.up
        take = min(self.per_block, self.n_out - o0)
        off = (start - a) // self.down * self.up
        return y[off:off + take].astype(np.float32)


def from_samples(samples: np.ndarray, rate: float) -> Audio:
    """Audio from an array shaped (n,) or (n, channels), any rate."""
    arr = np.asarray(samples, dtype=np.float32)
    if arr.ndim == 2:
        # Channels last (Blender's aud) or first (Praat): the longer axis is time.
        arr = arr.mean(axis=1 if arr.shape[0] >= arr.shape[1] else 0)
    if arr.size == 0:
        raise AudioError("the audio is empty (no samples)")
    if not np.all(np.isfinite(arr)):
        raise AudioError("the audio holds invalid samples (NaN or infinity)")
    return Audio(resample(arr, rate), MODEL_RATE)


def load(path: str | os.PathLike) -> Audio:
    """Read an audio file and convert it to 16 kHz mono.

    Raises :class:`AudioError` if it is missing, unreadable or empty.
    """
    path = os.fspath(path)
    if not os.path.exists(path):
        raise AudioError(f"audio file not found: {path}")
    if os.path.isdir(path):
        raise AudioError(f"audio path is a folder, not a file: {path}")
    if os.path.getsize(path) == 0:
        raise AudioError(f"audio file is empty (0 bytes): {path}")
    try:
        with open(path, "rb") as fh:
            head = fh.read(12)
    except OSError as exc:
        raise AudioError(f"cannot read audio file {path}: {exc.strerror or exc}") from None
    for magic, kind in _UNSUPPORTED:
        if head.startswith(magic) or (magic == b"ftyp" and head[4:8] == magic):
            raise AudioError(f"cannot read audio file {path}: it is {kind}, which this reader does not decode; "
                             "convert it to WAV or FLAC (in Blender, a sound strip of it works)")
    from .wavstream import read_wav

    wav = read_wav(path)
    if wav is not None:
        return wav
    import parselmouth

    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            sound = parselmouth.Sound(path)
    except Exception as exc:  # Praat says why in its own words
        reason = str(exc).strip().splitlines()[0].strip().rstrip(".") if str(exc).strip() else type(exc).__name__
        raise AudioError(f"cannot read audio file {path}: {reason}. "
                         "Use WAV, FLAC, MP3 or AIFF.") from None
    snd = from_samples(sound.values, sound.sampling_frequency)
    for w in caught:
        msg = " ".join(str(w.message).split())
        if "too small" in msg or "Missing samples" in msg:
            msg = "the file is cut short (truncated); the missing end was read as silence"
        snd.notes.append(f"audio file {path}: {msg}")
    return snd


#: Containers Praat cannot read, known by their first bytes, for a clearer
#: message than Praat's "Not an audio file".
_UNSUPPORTED = ((b"OggS", "an Ogg file (Vorbis or Opus)"), (b"ftyp", "an MP4/M4A file (AAC)"),
                (b"\x1aE\xdf\xa3", "a Matroska/WebM file"), (b"0&\xb2u", "a Windows Media file"))
