"""Speech after the transcript's last word: an actor's ad-lib at the end of
a line, or the next line left in the same take.

A forced alignment must lay the whole transcript over the whole clip, so
speech after the script's end pulls its last words along: they were
stretched over seconds of the ad-lib, and their own speech was taken for
unscripted speech.  When the check of the take (:mod:`.verify`) has found
unscripted speech, :func:`transcript_end` makes one more word pass whose
grammar lets a loop of any phones take the end of the clip.  Where the loop
takes at least :data:`MIN_TAIL` s, the transcript ends where its last word
ends in that pass; the caller aligns the transcript to the clip up to there
and checks the take again, and the rest is unscripted speech.
"""

from __future__ import annotations

from collections.abc import Sequence

from ..audio import Audio
from .decoding import _decoder
from .fillers import base_token
from .model import FRAME, AlignSettings

#: The acoustic model's speech phones, each a one-phone word of the loop.
LOOP_PHONES = ("AA AE AH AO AW AY B CH D DH EH ER EY F G HH IH IY JH K L M N NG OW OY P R S SH T TH UH UW "
               "V W Y Z ZH").split()
#: The grammar's weight of the loop after the last word (against 1 - it of no loop).
LOOP_WEIGHT = 0.1
#: The pass's word insertion penalty: each phone of the loop costs this much, so the loop takes
#: only speech the words do not fit (pocketsphinx's 0.65 let it take the last words of a line whose
#: middle had been cut from the transcript, with their own speech).
PHONE_PENALTY = 1e-3
#: The loop takes at least this much (s) for the transcript to end early.
MIN_TAIL = 0.4
#: Clips longer than this (s) are not searched this way (one pass holds the whole clip).
MAX_CLIP = 90.0


def transcript_end(audio: Audio, prons: Sequence[Sequence[str]], settings: AlignSettings) -> float | None:
    """Where (s) the last of the words ``prons`` ends when any speech may
    follow it; None if nothing follows it, the clip is too long, or the
    pass fails."""
    if not prons or audio.duration > MAX_CLIP:
        return None
    tokens = [f"w{i}" for i in range(len(prons))]
    loop = "( " + " | ".join(f"x{p}" for p in LOOP_PHONES) + " )"
    grammar = (f"#JSGF V1.0;\ngrammar tail;\n<loop> = {loop}+;\n"
               f"public <s> = {' '.join(tokens)} ( /{1 - LOOP_WEIGHT}/ <NULL> | /{LOOP_WEIGHT}/ <loop> );\n")
    try:
        decoder = _decoder(prons, 0, settings, more=[f"x{p} {p}" for p in LOOP_PHONES], wip=PHONE_PENALTY)
        decoder.add_jsgf_string("tail", grammar)
        decoder.activate_search("tail")
        decoder.start_utt()
        decoder.process_raw(audio.pcm16(), full_utt=True)
        decoder.end_utt()
        segs = [(sg.word, sg.start_frame, sg.end_frame + 1) for sg in (decoder.seg() or [])]
    except RuntimeError:
        return None
    words = [(base_token(w), a, b) for w, a, b in segs if base_token(w) in set(tokens)]
    loop_start = next((a for w, a, _ in segs if w.startswith("x")), None)
    if [w for w, _, _ in words] != tokens or loop_start is None:
        return None
    if audio.duration - loop_start * FRAME < MIN_TAIL:
        return None
    return words[-1][2] * FRAME
