"""Where the speech is: short-time energy and pocketsphinx's voice-activity
detector give one flag per 10 ms frame; pauses are the silent stretches
inside the speech."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..audio import Audio
from ..errors import AudioError
from .model import FRAME, AlignedWord


#: Frames of levels and voice activity computed at once (a minute): long
#: clips go block by block, so no copy of the whole clip is made.
_BLOCK_FRAMES = 6000


def frame_levels(audio: Audio, hop: float = FRAME, emphasis: bool = False) -> np.ndarray:
    """RMS level in dBFS of consecutive 25 ms windows every ``hop`` seconds;
    with ``emphasis``, of the signal's first difference (the pre-emphasis
    of speech recognisers, rising 6 dB an octave: the level of the speech
    band, a low rumble or thump counting 15-30 dB less than broadband)."""
    step = int(round(hop * audio.rate))
    win = int(round(0.025 * audio.rate))
    samples = audio.samples
    if len(samples) < win:
        x = samples.astype(np.float64)
        if emphasis:
            x = np.diff(x, prepend=x[:1])
        return 10.0 * np.log10(np.array([np.mean(x * x) if len(x) else 0.0]) + 1e-12)
    n = (len(samples) - win) // step + 1
    power = np.empty(n)
    for k0 in range(0, n, _BLOCK_FRAMES):
        k1 = min(n, k0 + _BLOCK_FRAMES)
        x = samples[k0 * step:(k1 - 1) * step + win].astype(np.float64)
        if emphasis:
            # The sample before the block (read as a slice: a long WAV file's samples are streamed).
            x = np.diff(x, prepend=np.asarray(samples[k0 * step - 1:k0 * step], np.float64) if k0 else x[:1])
        # Window sums from a running sum: each window's energy in O(1).
        run = np.concatenate([[0.0], np.cumsum(x * x)])
        starts = np.arange(k1 - k0) * step
        power[k0:k1] = np.maximum(run[starts + win] - run[starts], 0.0) / win
    return 10.0 * np.log10(power + 1e-12)


def speech_or_refuse(audio: Audio) -> tuple[np.ndarray, np.ndarray]:
    """The clip's frame levels and speech mask (:func:`speech_mask`); an
    :class:`AudioError` when no frame holds speech."""
    levels = frame_levels(audio)
    mask, _ = speech_mask(levels, audio)
    if not mask.any():
        raise AudioError(
            f"the audio holds no speech (loudest level {float(levels.max()):.0f} dBFS): "
            "check that the right sound is selected and that it is not muted")
    return levels, mask


def speech_mask(levels: np.ndarray, audio: Audio | None = None) -> tuple[np.ndarray, float]:
    """Which 10 ms frames may hold speech.  Returns (mask, threshold dB).

    The mask is built to be safe to cut at, not to be tight: a frame counts
    as speech if pocketsphinx's voice-activity detector (its loosest mode)
    hears a voice there, or if it is 10 dB above the noise floor.  Quiet,
    breathy or noisy speech (a speaker with a cold) defeats either test alone.
    """
    floor = float(np.percentile(levels, 10))
    peak = float(np.percentile(levels, 99))
    if peak < -70.0 or peak - floor < 6.0:
        return np.zeros(len(levels), bool), peak
    threshold = floor + 10.0
    mask = levels > threshold
    if audio is not None:
        import pocketsphinx

        vad = pocketsphinx.Vad(pocketsphinx.Vad.LOOSE, audio.rate, FRAME)
        fb = vad.frame_bytes
        per_block = fb // 2 * _BLOCK_FRAMES  # samples
        voiced = []
        for a in range(0, len(audio.samples), per_block):
            clip = np.clip(audio.samples[a:a + per_block], -1.0, 1.0)
            pcm = (clip * 32767.0).astype("<i2").tobytes()
            voiced.append(np.fromiter((vad.is_speech(pcm[k:k + fb]) for k in range(0, len(pcm) - fb + 1, fb)),
                                      bool))
        voiced = np.concatenate(voiced) if voiced else np.zeros(0, bool)
        n = min(len(voiced), len(mask))
        mask[:n] |= voiced[:n]
    # Close gaps shorter than 80 ms (stop closures).  Short blips are kept:
    # dropping them would put cuts inside quiet speech.
    return _close_runs(mask, False, 8), threshold


def runs(mask: np.ndarray, value: bool = True) -> np.ndarray:
    """[start, end) frames of every run of ``value`` in ``mask``, shape (runs, 2)."""
    m = (np.asarray(mask) == value).astype(np.int8)
    return np.flatnonzero(np.diff(np.concatenate(([0], m, [0])))).reshape(-1, 2)


def _close_runs(mask: np.ndarray, value: bool, shorter_than: int) -> np.ndarray:
    """``mask`` with the runs of ``value`` inside it (not at its ends)
    shorter than ``shorter_than`` frames turned over."""
    out = mask.copy()
    for i, j in runs(mask, value):
        if 0 < i and j < len(mask) and j - i < shorter_than:
            out[i:j] = not value
    return out


def pauses(mask: np.ndarray, min_pause: float) -> list[tuple[float, float]]:
    """Silent stretches inside the speech (not before or after it), in seconds."""
    if not mask.any():
        return []
    return [(int(i) * FRAME, int(j) * FRAME) for i, j in runs(mask, False)
            if 0 < i and j < len(mask) and (j - i) * FRAME >= min_pause]


def _longest_run(mask: np.ndarray) -> int:
    """Length of the longest run of True."""
    r = runs(mask)
    return int((r[:, 1] - r[:, 0]).max()) if len(r) else 0


def _speech_spans(mask: np.ndarray, start: float, end: float) -> list[tuple[float, float]]:
    """The runs of speech in ``mask`` between ``start`` and ``end`` s, as
    (start, end) s; the whole stretch if it holds none."""
    a, b = int(start / FRAME), int(math.ceil(end / FRAME))
    return [((a + i) * FRAME, (a + j) * FRAME) for i, j in runs(mask[a:b]).tolist()] or [(start, end)]


def unspoken_speech(mask: np.ndarray, words: list[AlignedWord], margin: float = 0.2
                    ) -> tuple[float, float, float] | None:
    """Speech (``mask``, one flag per :data:`FRAME`) that no word lies on,
    when there is much of it (over 0.5 s and a quarter of all speech): a
    transcript that lacks part of what is said.  (seconds, first, last)."""
    t = np.arange(len(mask)) * FRAME
    covered = np.zeros(len(mask), bool)
    for w in words:  # the frames with w.start - margin <= t <= w.end + margin
        covered[np.searchsorted(t, w.start - margin, "left"):np.searchsorted(t, w.end + margin, "right")] = True
    extra = mask & ~covered
    seconds = float(extra.sum()) * FRAME
    if seconds <= 0.5 or seconds <= 0.25 * float(mask.sum()) * FRAME:
        return None
    idx = np.flatnonzero(extra)
    return seconds, float(t[idx[0]]), float(t[idx[-1]] + FRAME)


def syllable_peaks(levels: np.ndarray, floor: float, prominence: float, cut_floor: float = np.inf,
                   smooth: int = 3, most: int | None = None) -> int:
    """How many syllables a stretch's frame ``levels`` (dB, one a frame)
    show: the peaks of the levels (averaged over ``smooth`` frames) at
    ``floor`` dB or more that stand ``prominence`` dB above the higher of
    the lowest dips on either side before a higher peak.  A peak at
    ``cut_floor`` dB or more with no higher one between it and an end of the
    stretch counts that end as a dip (a syllable cut off by the stretch, as
    loud as the voice).  Each syllable's vowel is a peak of the speech
    band's level; a breath, a hum or a held vowel is one.  Counting stops at
    ``most``."""
    x = np.asarray(levels, np.float64)
    if smooth > 1 and len(x) >= smooth:
        x = np.convolve(np.pad(x, smooth // 2, mode="edge"), np.ones(smooth) / smooth, mode="valid")
    n = len(x)
    if n == 0:
        return 0
    # Peaks: above the frame before, not below the frame after.
    rise = np.concatenate(([True], x[1:] > x[:-1]))
    keep = np.concatenate((x[:-1] >= x[1:], [True]))
    count = 0
    for i in np.flatnonzero(rise & keep & (x >= floor)).tolist():
        higher = np.flatnonzero(x[:i] > x[i])
        lo = int(higher[-1]) + 1 if len(higher) else 0         # back to the last higher frame
        higher = np.flatnonzero(x[i + 1:] > x[i])
        hi = i + int(higher[0]) if len(higher) else n - 1      # on to the next one
        cut = x[i] >= cut_floor
        left = -np.inf if lo == 0 and cut else x[lo:i + 1].min()      # no higher peak before it: the end is a dip
        right = -np.inf if hi == n - 1 and cut else x[i:hi + 1].min()
        if x[i] - max(left, right) >= prominence:
            count += 1
            if most is not None and count >= most:
                break
    return count


def covered_by(words: Sequence[AlignedWord], frames: int, margin: float = 0.0) -> np.ndarray:
    """One flag per :data:`.model.FRAME` (``frames`` of them): whether it lies
    within ``margin`` s of a spoken word of ``words``."""
    covered = np.zeros(frames, bool)
    for w in words:
        if w.spoken:
            covered[max(0, int((w.start - margin) / FRAME)):int(np.ceil((w.end + margin) / FRAME))] = True
    return covered


def voice_level(levels: np.ndarray, on: np.ndarray) -> float:
    """The level (dB) of the voice: the 90th percentile of the frame
    ``levels`` on the frames flagged ``on`` (of them all if none is)."""
    n = min(len(levels), len(on))
    part = levels[:n][np.asarray(on[:n], bool)]
    return float(np.percentile(part if len(part) else levels, 90))
