"""Plain PCM WAV files read without Praat; long ones a block at a time.

Praat reads a whole file into memory as 64-bit samples at the file's rate
(a 30-minute stereo recording at 44.1 kHz: 1.3 GB, and again as a copy).
A long plain PCM WAV is instead left on disk: the engine reads the stretch
it works on (a window, a minute of levels or pitch) from the file, reduced
to 16 kHz mono block by block, so memory does not grow with the length.
The samples are those Praat would give (integers scaled to [-1, 1),
channels averaged) and the resampling is the same as
:func:`.resampling.resample`.
A shorter plain PCM WAV is read whole, with the same samples.  A file cut
short (its header promises more frames than it holds) is read as Praat
reads it: the missing end is silence.  Anything else (other formats, WAV
the ``wave`` module cannot read) is left to the other decoders
(:mod:`.audio`).
"""

from __future__ import annotations

import os
import wave

import numpy as np

from .resampling import MODEL_RATE, BlockResampler

#: Files shorter than this (s) are read whole, by Praat.
LONG = 60.0
#: Resampled blocks kept (each about 0.4 MB): overlapping windows reuse them.
_CACHED = 6

_SCALE = {1: 128.0, 2: 32768.0, 3: 8388608.0, 4: 2147483648.0}


def _decode(raw: bytes, width: int, channels: int) -> np.ndarray:
    """PCM bytes -> float32 mono in [-1, 1)."""
    if width == 1:
        x = np.frombuffer(raw, np.uint8).astype(np.float32) - 128.0
    elif width == 3:
        b = np.frombuffer(raw, np.uint8).reshape(-1, 3)
        x = (b[:, 0].astype(np.int32) | (b[:, 1].astype(np.int32) << 8)
             | (b[:, 2].astype(np.int8).astype(np.int32) << 16)).astype(np.float32)
    else:
        x = np.frombuffer(raw, {2: "<i2", 4: "<i4"}[width]).astype(np.float32)
    x /= np.float32(_SCALE[width])
    if channels > 1:
        x = x.reshape(-1, channels).mean(axis=1, dtype=np.float32)
    return x


class WavSamples:
    """The 16 kHz mono samples of a long WAV file, read (and resampled) from
    the file when a stretch of them is asked for: ``samples[a:b]`` is a
    float32 array, the same samples :func:`.resampling.resample` would give for
    the whole file.  The whole signal is never held, so memory does not grow
    with the recording's length.  Slices only (step 1); ``np.asarray`` and
    ``astype`` read everything."""

    dtype = np.dtype(np.float32)
    ndim = 1

    def __init__(self, path: str, n: int, rate: int, width: int, channels: int):
        self.path, self.n, self.rate, self.width, self.channels = path, n, rate, width, channels
        self._blocks = None if rate == MODEL_RATE else BlockResampler(self._read_f64, n, rate, MODEL_RATE)
        self._n_out = n if self._blocks is None else self._blocks.n_out
        self._cache: dict[int, np.ndarray] = {}

    def __len__(self) -> int:
        return self._n_out

    @property
    def shape(self) -> tuple[int]:
        return (self._n_out,)

    def __getstate__(self):
        return {**self.__dict__, "_cache": {}}

    def _read(self, a: int, b: int) -> np.ndarray:
        """Input samples a..b (file frames), float32 mono."""
        with wave.open(self.path, "rb") as w:
            w.setpos(a)
            raw = w.readframes(b - a)
        # Past the end of a file cut short (or changed since it was opened): silence.
        return _decode(_whole_frames(raw, b - a, self.width, self.channels), self.width, self.channels)

    def _read_f64(self, a: int, b: int) -> np.ndarray:
        return self._read(a, b).astype(np.float64)

    def _block(self, j: int) -> np.ndarray:
        if j not in self._cache:
            if len(self._cache) >= _CACHED:
                self._cache.pop(next(iter(self._cache)))
            self._cache[j] = self._blocks.block(j)
        return self._cache[j]

    def __getitem__(self, key) -> np.ndarray:
        if not isinstance(key, slice):
            raise TypeError("WavSamples supports slices only")
        a, b, step = key.indices(self._n_out)
        if step != 1:
            raise TypeError("WavSamples supports slices of step 1 only")
        if b <= a:
            return np.zeros(0, np.float32)
        if self._blocks is None:
            return self._read(a, b)
        per = self._blocks.per_block
        parts = [self._block(j) for j in range(a // per, (b - 1) // per + 1)]
        first = a // per * per
        return np.concatenate(parts)[a - first:b - first] if len(parts) > 1 else parts[0][a - first:b - first].copy()

    def __array__(self, dtype=None, copy=None):
        whole = self[0:self._n_out]
        return whole if dtype is None else whole.astype(dtype)

    def astype(self, dtype) -> np.ndarray:
        return np.asarray(self).astype(dtype)


#: A data chunk this long is a placeholder (a recorder that never went back
#: to write the size): the file holds what it holds, and nothing is missing.
_UNKNOWN_SIZE = 0xFFFFFFFF - 64


def _plain_pcm(path: str) -> tuple[int, int, int, int, bool] | None:
    """(frames, rate, sample width, channels, cut short) of a plain PCM WAV
    file, or None for anything else.  A file cut short (fewer frames than
    its header promises) keeps the promised length, as Praat reads it."""
    try:
        with wave.open(path, "rb") as w:
            n, rate, width, channels = w.getnframes(), w.getframerate(), w.getsampwidth(), w.getnchannels()
            if width not in _SCALE or rate <= 0 or channels < 1 or n < 1:
                return None
            w.setpos(n - 1)
            if len(w.readframes(1)) == width * channels:
                return n, rate, width, channels, False
            held = _frames_held(w, n, width * channels)
    except (wave.Error, EOFError, OSError, ValueError):
        return None
    if held < 1:
        return None
    if n * width * channels >= _UNKNOWN_SIZE:
        return held, rate, width, channels, False
    return n, rate, width, channels, True


def _frames_held(w: wave.Wave_read, n: int, frame_bytes: int) -> int:
    """How many of its ``n`` promised frames the file holds (found by
    bisection: frame k is there if reading it gives a whole frame)."""
    lo, hi = 0, n - 1           # frame hi is missing; frames below lo are there
    while lo < hi:
        mid = (lo + hi) // 2
        w.setpos(mid)
        if len(w.readframes(1)) == frame_bytes:
            lo = mid + 1
        else:
            hi = mid
    return lo


def read_wav(path: str | os.PathLike) -> tuple[np.ndarray | WavSamples, int, bool] | None:
    """A plain PCM WAV file as (mono samples, their rate, cut short): a
    long one (:data:`LONG` s or more) left on disk as 16 kHz
    :class:`WavSamples` read from the file as they are needed, a shorter one
    read whole at its own rate (float32), with the samples Praat would give,
    without loading Praat (the pitch tracker may be loading it on the other
    core meanwhile).  A file cut short ends in silence.  None for anything
    else."""
    path = os.fspath(path)
    head = _plain_pcm(path)
    if head is None:
        return None
    n, rate, width, channels, cut = head
    if n / rate >= LONG:
        return WavSamples(path, n, rate, width, channels), MODEL_RATE, cut
    try:
        with wave.open(path, "rb") as w:
            raw = w.readframes(n)
    except (wave.Error, EOFError, OSError, ValueError):
        return None
    return _decode(_whole_frames(raw, n, width, channels), width, channels), rate, cut


def _whole_frames(raw: bytes, n: int, width: int, channels: int) -> bytes:
    """``raw`` filled up to ``n`` frames with silence (128 in 8-bit files,
    which are unsigned; 0 in the others): the whole samples of a last frame
    cut short are kept, as Praat keeps them."""
    if len(raw) == n * width * channels:
        return raw
    raw = raw[:len(raw) // width * width]
    return raw + (b"\x80" if width == 1 else b"\0") * (n * width * channels - len(raw))
