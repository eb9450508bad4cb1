"""Long WAV files read a block at a time.

Praat reads a whole file into memory as 64-bit samples at the file's rate
(a 30-minute stereo recording at 44.1 kHz: 1.3 GB, and again as a copy).
A long plain PCM WAV is instead read and reduced to 16 kHz mono block by
block, into the one 32-bit array the engine keeps (3.8 MB a minute).  The
samples are those Praat would give (integers scaled to [-1, 1), channels
averaged) and the resampling is the same as :func:`.audio.resample`.
Anything else (short files, other formats, WAV the ``wave`` module cannot
read, a file cut short) is left to Praat, which says what is wrong with it.
"""

from __future__ import annotations

import os
import wave

import numpy as np

from .audio import MODEL_RATE, Audio, resample_blocks

#: Files shorter than this (s) are read whole, by Praat.
LONG = 60.0
#: Samples read at once when the file is already at the model's rate.
_CHUNK = 1 << 20

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


def read_long_wav(path: str | os.PathLike) -> Audio | None:
    """The file as 16 kHz mono :class:`Audio`, read block by block, or None
    when it is not a long, complete, plain PCM WAV file (Praat reads it then)."""
    try:
        w = wave.open(os.fspath(path), "rb")
    except (wave.Error, EOFError, OSError, ValueError):
        return None
    with w:
        n, rate, width, channels = w.getnframes(), w.getframerate(), w.getsampwidth(), w.getnchannels()
        if width not in _SCALE or rate <= 0 or channels < 1 or n / rate < LONG:
            return None
        frame_bytes = width * channels
        short = []

        def read(a: int, b: int) -> np.ndarray:
            w.setpos(a)
            raw = w.readframes(b - a)
            if len(raw) < (b - a) * frame_bytes:
                short.append(a)
                raw = raw[:len(raw) // frame_bytes * frame_bytes] + bytes((b - a) * frame_bytes - len(raw))
            return _decode(raw, width, channels)

        try:
            if rate == MODEL_RATE:
                samples = np.empty(n, np.float32)
                for a in range(0, n, _CHUNK):
                    samples[a:a + _CHUNK] = read(a, min(n, a + _CHUNK))
            else:
                samples = resample_blocks(lambda a, b: read(a, b).astype(np.float64), n, rate, MODEL_RATE)
        except (wave.Error, EOFError, OSError, ValueError):
            return None
    if short:
        return None  # cut short: Praat reads it and says so
    return Audio(samples, MODEL_RATE)
