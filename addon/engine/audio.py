"""Audio in, reduced to 16 kHz mono, the rate of the acoustic model: a file
(:func:`load`, the one reader of the command line, batch runs, arousal and
learning) or samples handed over by a host program (:func:`from_samples`:
Blender decodes its own sound strips).

:func:`load` reads

* plain PCM WAV itself (:mod:`.wavstream`), with the samples Praat gives;
* WAV of every other kind, FLAC, Ogg Vorbis, Ogg Opus, MP3 and AIFF with
  soundfile, and M4A/AAC and the sound track of MP4, MOV and MKV/WebM
  video with PyAV (:mod:`.decoders`), each imported only when a file needs
  it;
* without those packages (the Blender extension does not bundle them),
  WAV, FLAC, MP3 and AIFF with Praat.

Long files of any of these stay out of memory: a long WAV is read from the
file a stretch at a time, other formats are decoded and resampled a block at
a time into a temporary file.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from . import decoders, wavstream
from .errors import AudioError
from .resampling import MODEL_RATE, resample


#: The noise floor under the sound pocketsphinx hears, in dB under the clip's loud level
#: (:meth:`Audio.loud_level`).  The recogniser's features of a quiet frame (a pause, a fading /s/, a
#: stop's closure) follow whatever little sound is there: exact digital silence, a noise gate or a
#: lossy codec's rounding in a pause moved boundaries by up to 0.2 s.  Over the floor they are alike:
#: bench/format_alignment.py.
FLOOR_DB = -40.0
#: Frames of the loud level (s) and its percentile.
_LEVEL_FRAME, _LEVEL_PERCENTILE = 0.01, 95.0
_BLOCK = 1 << 20


def floor_noise(a: int, b: int) -> np.ndarray:
    """Fixed white noise of RMS 1 for samples a..b: each sample's value
    depends on its index alone, so every stretch of a clip gets the same
    noise wherever it is cut."""
    h = np.arange(a, b, dtype=np.uint64) * np.uint64(2654435761) + np.uint64(12345)
    h &= np.uint64(0xFFFFFFFF)
    h = ((h ^ (h >> np.uint64(13))) * np.uint64(1274126177)) & np.uint64(0xFFFFFFFF)
    return (h.astype(np.float64) / 2.0 ** 32 - 0.5) * np.sqrt(12.0)


@dataclass
class Audio:
    samples: np.ndarray  # float32, mono, in [-1, 1]
    rate: int
    #: What the reader had to repair (a file cut short ...): shown to the user as warnings.
    notes: list = field(default_factory=list)
    _loud: float | None = field(default=None, repr=False, compare=False)

    @property
    def duration(self) -> float:
        return len(self.samples) / self.rate

    def loud_level(self) -> float:
        """The RMS of the clip's loud frames: the 95th percentile of its
        10 ms frames' RMS (read a block at a time, computed once)."""
        if self._loud is None:
            size = max(1, int(round(_LEVEL_FRAME * self.rate)))
            step = _BLOCK // size * size
            rms = []
            for i in range(0, len(self.samples), step):
                x = np.asarray(self.samples[i:i + step], np.float64)
                n = len(x) // size * size
                if n:
                    rms.append(np.sqrt((x[:n].reshape(-1, size) ** 2).mean(axis=1)))
            self._loud = float(np.percentile(np.concatenate(rms), _LEVEL_PERCENTILE)) if rms else 0.0
        return self._loud

    def within(self, start: float, end: float) -> Audio:
        """The clip up to ``end`` s, silent before ``start`` s, heard over the
        whole clip's noise floor."""
        return self.silenced([(0.0, start)], end)

    def silenced(self, spans: Sequence[tuple[float, float]], end: float | None = None) -> Audio:
        """The clip (up to ``end`` s) with the (start, end) s ``spans``
        silent, heard over the whole clip's noise floor."""
        n = len(self.samples) if end is None else min(len(self.samples), max(1, int(round(end * self.rate))))
        x = np.array(self.samples[0:n], np.float32)
        for a, b in spans:
            x[max(0, int(round(a * self.rate))):max(0, int(round(b * self.rate)))] = 0.0
        return Audio(x, self.rate, list(self.notes), self.loud_level())

    def pcm16(self, start: float = 0.0, end: float | None = None, floor: bool = True) -> bytes:
        """16-bit samples of start..end s for pocketsphinx; for forced
        alignment over the clip's noise floor (:data:`FLOOR_DB`), for
        recognition (``floor=False``) as they are: the floor's hiss would be
        heard as fricatives there."""
        n = len(self.samples)
        a = min(n, max(0, int(round(start * self.rate))))
        b = n if end is None else min(n, max(a, int(round(end * self.rate))))
        amp = self.loud_level() * 10.0 ** (FLOOR_DB / 20.0) * 32767.0 if floor else 0.0
        out = np.empty(b - a, "<i2")
        for i in range(a, b, _BLOCK):     # a block at a time: a long clip is never held as float64
            j = min(b, i + _BLOCK)
            x = np.clip(np.asarray(self.samples[i:j], np.float64), -1.0, 1.0) * 32767.0
            if amp:
                x += floor_noise(i, j) * amp
            out[i - a:j - a] = np.clip(np.round(x), -32768, 32767)
        return out.tobytes()


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


#: What the reader reads, for messages.
FORMATS = "WAV, FLAC, Ogg Vorbis or Opus, MP3, AIFF, M4A/AAC or a video with sound (MP4, MOV, MKV)"

#: File kinds known by their first bytes: (test, what it is, the decoders to try in order).  Opus goes to
#: FFmpeg first (twice as fast as libsndfile on it: bench/decode_formats.py), and so does MP3: the
#: libmpg123 in soundfile's wheel writes its complaints about some frames straight to the terminal (the
#: samples are the same).
_SOUND = ("soundfile", "av")
_VIDEO = ("av",)
_KINDS = (
    (lambda h: h[:4] == b"RIFF" and h[8:12] == b"WAVE", "a WAV file", _SOUND),
    (lambda h: h[:4] in (b"RF64", b"BW64"), "a WAV file (RF64)", _SOUND),
    (lambda h: h[:4] == b"RIFF" and h[8:12] == b"AVI ", "an AVI video", _VIDEO),
    (lambda h: h[:4] == b"OggS" and h[28:36] == b"OpusHead", "an Ogg Opus file", ("av", "soundfile")),
    (lambda h: h[:4] == b"OggS" and h[28:35] == b"\x01vorbis", "an Ogg Vorbis file", _SOUND),
    (lambda h: h[:4] == b"OggS", "an Ogg file (Vorbis or Opus)", _SOUND),
    (lambda h: h[:4] == b"fLaC", "a FLAC file", _SOUND),
    (lambda h: h[:3] == b"ID3" or (h[0] == 0xFF and (h[1] & 0xE0) == 0xE0 and (h[1] & 0x06) != 0), "an MP3 file",
     ("av", "soundfile")),
    (lambda h: h[0] == 0xFF and (h[1] & 0xF6) == 0xF0, "an AAC file (ADTS)", _VIDEO),
    (lambda h: h[:4] == b"FORM" and h[8:12] in (b"AIFF", b"AIFC"), "an AIFF file", _SOUND),
    (lambda h: h[:4] == b"caff", "a CAF file", _SOUND),
    (lambda h: h[4:8] == b"ftyp", "an MP4/M4A/MOV file", _VIDEO),
    (lambda h: h[4:8] in (b"moov", b"mdat", b"wide", b"free", b"skip"), "a QuickTime (MOV) file", _VIDEO),
    (lambda h: h[:4] == b"\x1aE\xdf\xa3", "a Matroska/WebM file", _VIDEO),
    (lambda h: h[:4] == b"0&\xb2u", "a Windows Media file", _VIDEO),
)
#: Praat's readers (when the decoders are not installed).
_PRAAT = ("a WAV file", "a FLAC file", "an MP3 file", "an AIFF file", None)
_INSTALL = {"soundfile": "soundfile", "av": "av (PyAV)"}


def _kind(head: bytes) -> tuple[str | None, tuple[str, ...]]:
    """What a file is by its first bytes, and the decoders to try."""
    head = head.ljust(64, b"\0")
    for test, what, order in _KINDS:
        if test(head):
            return what, order
    return None, _SOUND


def _looks_like_text(head: bytes) -> bool:
    try:
        text = head.decode("utf-8")
    except UnicodeDecodeError:
        return False
    return bool(text) and all(c.isprintable() or c in "\t\r\n" for c in text)


def load(path: str | os.PathLike) -> Audio:
    """Read an audio file and convert it to 16 kHz mono.

    Raises :class:`AudioError` if it is missing, unreadable or empty, with
    one line naming the file and what it is.
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
            head = fh.read(64)
    except OSError as exc:
        raise AudioError(f"cannot read audio file {path}: {exc.strerror or exc}") from None
    what, order = _kind(head)
    wav = wavstream.read_wav(path) if what == "a WAV file" else None
    if wav is not None:
        samples, rate, cut = wav
        snd = Audio(samples, rate) if isinstance(samples, wavstream.WavSamples) else from_samples(samples, rate)
        if cut:
            snd.notes.append(f"audio file {path}: {_CUT_SHORT}")
        return snd
    missing, reasons = [], []
    for package in order:
        try:
            samples, rate, cut = decoders.decode(path, package)
        except decoders.Missing:
            missing.append(package)
            continue
        except decoders.Undecodable as exc:
            reasons.append(str(exc))
            continue
        if isinstance(samples, decoders.DiskSamples):
            snd = Audio(samples, rate)
        else:
            try:
                snd = from_samples(samples, rate)
            except AudioError as exc:    # no samples, or samples that are not numbers
                raise AudioError(f"cannot read audio file {path}: it is {what or 'a sound file'}, but {exc}") \
                    from None
        if cut:
            snd.notes.append(f"audio file {path}: {cut}")
        return snd
    if missing and what in _PRAAT:
        return _praat(path, what)
    if what is None and _looks_like_text(head):
        what = "a text file, not audio"
    if missing and not reasons:
        package = "soundfile" if "soundfile" in missing else missing[0]    # the smaller, where it reads the file
        raise AudioError(f"cannot read audio file {path}: it is {what}; reading it needs the Python package "
                         f"{_INSTALL[package]} (pip install {package}), or convert it to WAV or FLAC "
                         "(in Blender, a sound strip of it works)")
    if what is None:
        raise AudioError(f"cannot read audio file {path}: it is not a sound file ({reasons[0]}). Use {FORMATS}")
    if what.startswith("a text file"):
        raise AudioError(f"cannot read audio file {path}: it is {what}. Use {FORMATS}")
    raise AudioError(f"cannot read audio file {path}: it is {what}, but it cannot be decoded ({reasons[0]})")


_CUT_SHORT = "the file is cut short (truncated); the missing end was read as silence"


def _praat(path: str, what: str | None) -> Audio:
    """The file read by Praat (WAV, FLAC, MP3, AIFF and Praat's own formats)."""
    import parselmouth

    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            sound = parselmouth.Sound(path)
    except Exception as exc:  # noqa: BLE001 - Praat says why in its own words
        reason = str(exc).strip().splitlines()[0].strip().rstrip(".") if str(exc).strip() else type(exc).__name__
        it = f"it is {what} that Praat cannot read ({reason})" if what else reason
        raise AudioError(f"cannot read audio file {path}: {it}. "
                         "Use WAV, FLAC, MP3 or AIFF (other formats need the Python packages soundfile and av).") \
            from None
    snd = from_samples(sound.values, sound.sampling_frequency)
    for w in caught:
        msg = " ".join(str(w.message).split())
        if "too small" in msg or "Missing samples" in msg:
            msg = _CUT_SHORT
        snd.notes.append(f"audio file {path}: {msg}")
    return snd
