"""Audio formats beyond plain PCM WAV, decoded a block at a time by two
packages from PyPI, each imported only when a file needs it:

* soundfile (libsndfile, bundled in its wheel: 3.7 MB installed): WAV of
  every kind (8-32-bit integer, float, extensible, RF64), FLAC, AIFF, Ogg
  Vorbis, CAF ... (and Ogg Opus and MP3, which it reads too);
* av (PyAV, FFmpeg bundled in its wheel: 102 MB installed): M4A/AAC and the
  sound track of MP4, MOV, MKV/WebM and other video (and anything else
  FFmpeg reads).  :mod:`.audio` sends Opus and MP3 here first.

The Blender extension bundles neither (Blender decodes its own sound), so
both are optional here: :class:`Missing` says which one a file needs.

Decoded samples are mixed to mono (channels averaged, as Praat does).  A
file shorter than :data:`.wavstream.LONG` is returned whole at its own
rate.  A longer one is resampled to 16 kHz as it is decoded, block by block
(:class:`.resampling.StreamResampler`), and kept in a temporary file
(:class:`DiskSamples`) that the engine reads a stretch at a time, so memory
does not grow with its length (the file takes 3.84 MB a minute on disk, and
is deleted when the audio is no longer used or the program ends).  A file
damaged or cut short is read up to where its sound breaks, with a note.
"""

from __future__ import annotations

import itertools
import os
import tempfile
import threading
from collections.abc import Callable, Iterator

import numpy as np

from .resampling import MODEL_RATE, StreamResampler
from .wavstream import LONG

#: Frames read from the file at a time (libsndfile), or passed on at a time (FFmpeg's short frames
#: gathered); a read that fails loses its block, so libsndfile's are shorter.
BLOCK = 1 << 16
_SF_BLOCK = 1 << 14


class Missing(Exception):
    """The package that decodes a file is not installed (its PyPI name)."""


class Undecodable(Exception):
    """The decoder cannot read the file (its reason, in its own words)."""


Blocks = Iterator[np.ndarray]


class Stream:
    """A file being decoded: its rate, the seconds it says it lasts (or
    None), its mono float32 blocks (iterate), and, once they have run out,
    why they stopped early (a file damaged or cut short) or None."""

    def __init__(self, rate: int, declared: float | None):
        self.rate, self.declared, self.stopped = rate, declared, None
        self._blocks: Blocks = iter(())

    def __iter__(self) -> Blocks:
        return self._blocks

    def stop(self, done: int, reason: str) -> None:
        """Decoding failed after ``done`` samples: the rest is not read (none read: the file cannot be)."""
        if done == 0:
            raise Undecodable(reason)
        self.stopped = f"its sound could be decoded up to {done / self.rate:.2f} s only ({reason})"


def soundfile_blocks(path: str) -> Stream:
    """A file libsndfile reads."""
    try:
        import soundfile
    except ImportError:
        raise Missing("soundfile") from None
    try:
        f = soundfile.SoundFile(path)
    except (soundfile.LibsndfileError, RuntimeError, ValueError) as exc:
        raise Undecodable(_sf_reason(exc)) from None
    rate = int(f.samplerate)
    stream = Stream(rate, f.frames / rate if 0 < f.frames < 1 << 62 else None)

    def blocks() -> Blocks:
        with f:
            done = 0
            try:
                for block in f.blocks(blocksize=_SF_BLOCK, dtype="float32", always_2d=True):
                    done += len(block)
                    yield block[:, 0] if block.shape[1] == 1 else block.mean(axis=1, dtype=np.float32)
            except (soundfile.LibsndfileError, RuntimeError) as exc:
                stream.stop(done, _sf_reason(exc))

    stream._blocks = blocks()
    return stream


def _sf_reason(exc: Exception) -> str:
    reason = getattr(exc, "error_string", None) or str(exc)
    if reason.startswith("Error opening") and ": " in reason:    # "Error opening 'x.ogg': Format not recognised."
        reason = reason.split(": ", 1)[1]
    return reason.replace("Error : ", "").strip().rstrip(".")


def av_blocks(path: str) -> Stream:
    """The first sound track of a file FFmpeg reads (video frames are
    skipped without being decoded)."""
    try:
        import av
    except ImportError:
        raise Missing("av") from None
    try:
        container = av.open(path)
    except (av.error.FFmpegError, UnicodeDecodeError, ValueError) as exc:
        raise Undecodable(_av_reason(exc)) from None
    if not container.streams.audio:
        container.close()
        raise Undecodable("it holds no sound track")
    track = container.streams.audio[0]
    frames = container.decode(track)
    try:
        first = next(frames)
    except StopIteration:
        container.close()
        raise Undecodable("its sound track holds no samples") from None
    except av.error.FFmpegError as exc:
        container.close()
        raise Undecodable(_av_reason(exc)) from None
    rate = int(first.sample_rate)
    stream = Stream(rate, float(track.duration * track.time_base) if track.duration and track.time_base else None)

    def blocks() -> Blocks:
        with container:
            done, parts, held = 0, [], 0
            try:
                for frame in itertools.chain([first], frames):
                    if frame.sample_rate != rate:
                        raise Undecodable(f"its sample rate changes from {rate} to {frame.sample_rate} Hz "
                                          f"at {done / rate:.2f} s")
                    x = _av_mono(frame)
                    parts.append(x)
                    held += len(x)
                    done += len(x)
                    if held >= BLOCK:       # frames are short (about 1024 samples): pass on larger blocks
                        yield np.concatenate(parts)
                        parts, held = [], 0
            except av.error.FFmpegError as exc:
                stream.stop(done, _av_reason(exc))
            if parts:
                yield np.concatenate(parts)

    stream._blocks = blocks()
    return stream


#: Integer sample formats FFmpeg decodes to: (offset, scale) to [-1, 1).
_AV_INT = {np.dtype(np.uint8): (128.0, 128.0), np.dtype(np.int16): (0.0, 32768.0),
           np.dtype(np.int32): (0.0, 2147483648.0), np.dtype(np.int64): (0.0, 9223372036854775808.0)}


def _av_mono(frame) -> np.ndarray:
    """A decoded audio frame -> float32 mono samples in [-1, 1]."""
    x = frame.to_ndarray()
    channels = len(frame.layout.channels)
    if not frame.format.is_planar:
        x = x.reshape(-1, channels).T
    if x.dtype in _AV_INT:
        offset, scale = _AV_INT[x.dtype]
        x = (x.astype(np.float32) - np.float32(offset)) / np.float32(scale)
    x = x.astype(np.float32, copy=False)
    return x[0] if channels == 1 else x.mean(axis=0, dtype=np.float32)


def _av_reason(exc: Exception) -> str:
    return str(getattr(exc, "strerror", None) or exc).strip().rstrip(".")


#: The decoders by the name of the package they need.
DECODERS: dict[str, Callable[[str], Stream]] = {"soundfile": soundfile_blocks, "av": av_blocks}

#: A file whose sound ends this much (s, or this share of it) before the length it declares is cut short.
_SHORT_BY, _SHORT_SHARE = 0.25, 0.02


def _note(stream: Stream, n: int) -> str | None:
    """What to tell the user about a file that is damaged or cut short."""
    if stream.stopped:
        return f"the file is damaged or cut short: {stream.stopped}"
    declared = stream.declared
    if declared is None or n / stream.rate >= declared - max(_SHORT_BY, _SHORT_SHARE * declared):
        return None
    return f"the file is cut short: it says it lasts {declared:.2f} s and its sound ends at {n / stream.rate:.2f} s"


def decode(path: str, package: str) -> tuple[np.ndarray | DiskSamples, int, str | None]:
    """The file's mono samples, their rate and a note if the file is damaged
    or cut short, decoded by ``package``: a file shorter than :data:`LONG`
    whole, at its own rate; a longer one at 16 kHz in a
    :class:`DiskSamples`.  Raises :class:`Missing` or :class:`Undecodable`
    (also for samples that are not numbers)."""
    blocks = DECODERS[package](path)
    rate = blocks.rate
    head, n = [], 0
    for x in blocks:
        head.append(x)
        n += len(x)
        if n >= LONG * rate:
            break
    else:
        return (np.concatenate(head) if head else np.zeros(0, np.float32)), rate, _note(blocks, n)
    n = 0
    head.reverse()
    store, resampler = DiskSamples(), StreamResampler(rate, MODEL_RATE)

    def read_on() -> Blocks:
        while head:             # what was read first, let go of as it is used
            yield head.pop()
        yield from blocks

    for x in read_on():
        if not np.all(np.isfinite(x)):
            raise Undecodable("it holds invalid samples (NaN or infinity)")
        n += len(x)
        store.append(resampler.push(x))
    store.append(resampler.finish())
    return store.done(), MODEL_RATE, _note(blocks, n)


class DiskSamples:
    """Mono float32 samples kept in a temporary file and read from it a
    stretch at a time: ``samples[a:b]`` is a float32 array.  The file is
    deleted when it is closed (when these samples are no longer used, or the
    program ends).  Forked worker processes read the same file.  Pickled,
    the samples travel as a plain array.  Slices only (step 1);
    ``np.asarray`` and ``astype`` read everything."""

    dtype = np.dtype(np.float32)
    ndim = 1

    def __init__(self):
        self._file = tempfile.TemporaryFile(prefix="lipsync-audio-", suffix=".f32")
        self._n = 0
        self._lock = threading.Lock()   # where there is no pread: one seek-and-read at a time

    def append(self, x: np.ndarray) -> None:
        self._file.write(np.asarray(x, "<f4").tobytes())
        self._n += len(x)

    def done(self) -> DiskSamples:
        """Written: the samples can be read."""
        self._file.flush()
        return self

    def __len__(self) -> int:
        return self._n

    @property
    def shape(self) -> tuple[int]:
        return (self._n,)

    def _read(self, a: int, b: int) -> np.ndarray:
        size, at = (b - a) * 4, a * 4
        if hasattr(os, "pread"):
            parts, fd = [], self._file.fileno()
            while size > 0:
                part = os.pread(fd, size, at)
                if not part:
                    break
                parts.append(part)
                size, at = size - len(part), at + len(part)
            raw = b"".join(parts)
        else:
            with self._lock:
                self._file.seek(at)
                raw = self._file.read(size)
        return np.frombuffer(raw, "<f4").astype(np.float32)

    def __getitem__(self, key) -> np.ndarray:
        if not isinstance(key, slice):
            raise TypeError("DiskSamples supports slices only")
        a, b, step = key.indices(self._n)
        if step != 1:
            raise TypeError("DiskSamples supports slices of step 1 only")
        return self._read(a, b) if b > a else np.zeros(0, np.float32)

    def __array__(self, dtype=None, copy=None):
        whole = self[0:self._n]
        return whole if dtype is None else whole.astype(dtype)

    def astype(self, dtype) -> np.ndarray:
        return np.asarray(self).astype(dtype)

    def __reduce__(self):
        return np.asarray, (np.asarray(self),)
