"""Speech too fast for the aligner's frames.

The decoder gives every phone at least :data:`.model.SHORTEST_FRAMES`
frames of 10 ms.  Fast speech (an excited, angry or hurried line; a take
sped up in editing) says phones in less: the aligner then squeezes most of
them to that length and takes the time from the pauses around them, or
finds no path at all and places the words by estimate, although the
transcript is right.  Such a line is aligned a second time on a copy
slowed by :data:`SLOWER` (Praat's overlap-add, the pitch kept), and the
times are scaled back.  On EmoDB's acted emotional German at its own speed
the slowed copy gives as many phone starts within 20 ms of the hand labels
as the clip itself (0.857 at 1.5 against 0.861), so it is the better
alignment wherever the first one could not give the phones their time.
"""

from __future__ import annotations

import numpy as np

from ..audio import Audio
from .model import Alignment, at_shortest

#: How much longer the slowed copy is.
SLOWER = 1.5
#: Clips longer than this (s) are not slowed: a take of that length holds pauses to give its phones room.
LONGEST = 30.0
#: A line is slowed when at least this share of its phones aligned acoustically are at the shortest
#: length (right transcripts of normal speech: 5-31 %; of fast or hoarse short lines: up to 85 %),
#: or when some were placed by estimate.  At 0.4 as at 0.5, bench/false_alarms.py's MFA and EmoDB
#: lines, sped up to 1.5 times, give no false alarm; at 0.5 a tenth of its short lines are slowed.
SQUEEZED = 0.5


def squeezed_share(al: Alignment) -> float:
    """The share of the phones aligned acoustically that have the shortest length."""
    lengths = [p.end - p.start for p in al.phones if not p.estimated]
    return float(np.mean([at_shortest(x) for x in lengths])) if lengths else 0.0


def too_fast(al: Alignment) -> bool:
    """Whether ``al`` shows phones with too little time: many squeezed, or some placed by estimate."""
    return al.n_estimated > 0 or squeezed_share(al) >= SQUEEZED


def slowed(snd: Audio, factor: float = SLOWER) -> Audio:
    """``snd`` ``factor`` times longer, the pitch kept.  Praat's overlap-add
    draws random numbers: they are seeded for it, so that the same clip is
    always slowed alike (and aligned alike), then unseeded again."""
    import parselmouth
    from parselmouth.praat import call, run

    sound = parselmouth.Sound(np.asarray(snd.samples, np.float64), sampling_frequency=snd.rate)
    run("random_initializeWithSeedUnsafelyButPredictably (1)")
    try:
        longer = call(sound, "Lengthen (overlap-add)", 75, 600, factor)
    finally:
        run("random_initializeSafelyAndUnpredictably ()")
    return Audio(np.asarray(longer.values[0], np.float32), snd.rate, list(snd.notes), snd.loud_level())


def scaled(al: Alignment, factor: float, duration: float) -> Alignment:
    """``al`` (aligned to a copy ``factor`` times longer) on the clip's own
    time, ``duration`` s long; in place."""
    for item in al.words + al.phones:
        item.start = min(duration, item.start / factor)
        item.end = min(duration, item.end / factor)
    al.unscripted = [(a / factor, b / factor, t) for a, b, t in al.unscripted]
    al.duration = duration
    return al


def better(first: Alignment, slow: Alignment) -> bool:
    """Whether the alignment of the slowed copy is the better one: fewer
    phones placed by estimate, or as many and fewer squeezed."""
    if slow.n_estimated != first.n_estimated:
        return slow.n_estimated < first.n_estimated
    return squeezed_share(slow) < squeezed_share(first)
