"""Speech before the transcript's first word or after its last: a slate or an
actor's ad-lib before the line, an ad-lib after it, the next line left in
the same take.

A forced alignment must lay the whole transcript over the whole clip, so
such speech pulls the script's first or last words over it: they were
stretched or moved by seconds, and their own speech was taken for
unscripted speech.  When the first alignment shows it (the check of the
take, :mod:`.verify`, found unscripted speech, or a word at either edge
holds a phone :data:`STRETCHED` s long), :func:`script_bounds` makes one
more word pass whose grammar lets a loop of any phones take the start and
the end of the clip.  :func:`edges` keeps what that pass says where it
moves the script's edge: the caller aligns the transcript to the clip
between the two, and checks the take again over the whole clip.
"""

from __future__ import annotations

from collections.abc import Sequence

from ..audio import Audio
from .decoding import _decoder
from .fillers import base_token, is_hesitation
from .model import FRAME, AlignSettings, Alignment
from .speech import frame_levels, speech_mask
from .verify import edit_path

#: The acoustic model's speech phones, each a one-phone word of the loop.
LOOP_PHONES = ("AA AE AH AO AW AY B CH D DH EH ER EY F G HH IH IY JH K L M N NG OW OY P R S SH T TH UH UW "
               "V W Y Z ZH").split()
#: The grammar's weight of a loop before the first word and after the last (against 1 - it of none).
LOOP_WEIGHT = 0.1
#: The pass's word insertion penalty: each phone of a loop costs this much, so a loop takes only
#: speech the words do not fit (pocketsphinx's 0.65 let it take the last words of a line whose
#: middle had been cut from the transcript, with their own speech).
PHONE_PENALTY = 1e-3
#: A loop takes at least this much (s) for the script's edge to move.
MIN_LOOP = 0.4
#: Clips longer than this (s) are not searched this way (one pass holds the whole clip).
MAX_CLIP = 90.0
#: A phone this long (s) in a word at either edge of the first alignment shows the word pulled.
STRETCHED = 0.5
#: The words at either edge that are looked at for it.
EDGE_WORDS = 3
#: An edge moves only by more than this (s).
SHIFT = 0.1
#: Speech after the script pulls its last few words: a new end moves at most this many (speech cut
#: from the middle of a transcript leaves its last words at the clip's end, where the loop may take
#: them too).
MAX_MOVED = 3
#: The words a new end moves are heard at the clip's end in this share of their phones: they were
#: said there, and the first alignment stands.
HEARD = 0.5
#: Room (s) left beyond the script's edge, and how much further (s) it may reach, to the next pause.
MARGIN, REACH = 0.1, 0.3


def script_bounds(audio: Audio, prons: Sequence[Sequence[str]],
                  settings: AlignSettings) -> tuple[float | None, float | None]:
    """(where the first of the words ``prons`` starts, where the last ends)
    when any speech may come before and after them; each None where nothing
    does (or the clip is too long, or the pass fails)."""
    if not prons or audio.duration > MAX_CLIP:
        return None, None
    tokens = [f"w{i}" for i in range(len(prons))]
    loop = "( " + " | ".join(f"x{p}" for p in LOOP_PHONES) + " )"
    maybe = f"( /{1 - LOOP_WEIGHT}/ <NULL> | /{LOOP_WEIGHT}/ <loop> )"
    grammar = f"#JSGF V1.0;\ngrammar edges;\n<loop> = {loop}+;\npublic <s> = {maybe} {' '.join(tokens)} {maybe};\n"
    try:
        decoder = _decoder(prons, 0, settings, more=[f"x{p} {p}" for p in LOOP_PHONES], wip=PHONE_PENALTY)
        decoder.add_jsgf_string("edges", grammar)
        decoder.activate_search("edges")
        decoder.start_utt()
        decoder.process_raw(audio.pcm16(), full_utt=True)
        decoder.end_utt()
        segs = [(sg.word, sg.start_frame, sg.end_frame + 1) for sg in (decoder.seg() or [])]
    except RuntimeError:
        return None, None
    known = set(tokens)
    at = [k for k, (w, _, _) in enumerate(segs) if base_token(w) in known]
    if [base_token(segs[k][0]) for k in at] != tokens:
        return None, None
    before = [(a, b) for w, a, b in segs[:at[0]] if w.startswith("x")]
    after = [(a, b) for w, a, b in segs[at[-1] + 1:] if w.startswith("x")]
    start = segs[at[0]][1] * FRAME if before and (before[-1][1] - before[0][0]) * FRAME >= MIN_LOOP else None
    end = segs[at[-1]][2] * FRAME if after and (after[-1][1] - after[0][0]) * FRAME >= MIN_LOOP else None
    return start, end


def _pulled(al: Alignment) -> bool:
    """Whether the first alignment shows the script pulled at an edge."""
    script = [k for k, w in enumerate(al.words) if w.spoken and not w.recognized and not is_hesitation(w.text)]
    edge = set(script[:EDGE_WORDS] + script[-EDGE_WORDS:])
    return bool(al.unscripted) or any(p.end - p.start >= STRETCHED for p in al.phones if p.word_index in edge)


def edges(snd: Audio, al: Alignment, prons: Sequence[Sequence[str]],
          settings: AlignSettings) -> tuple[float, float] | None:
    """(start, end) s of the stretch of ``snd`` the transcript is to be
    aligned to, when speech before or after it pulled its first or last
    words in the first alignment ``al``; None to keep ``al``."""
    script = [w for w in al.words if w.spoken and not w.recognized]
    if not script or not _pulled(al):
        return None
    start, end = script_bounds(snd, prons, settings)
    if start is not None and start < script[0].start + SHIFT:
        start = None
    if end is not None and (end > script[-1].end - SHIFT or
                            sum(w.end > end + SHIFT for w in script) > MAX_MOVED):
        end = None
    if start is None and end is None:
        return None
    mask, _ = speech_mask(frame_levels(snd), snd)
    if start is not None:    # a loop may take a word's first sound: back to the pause before, within REACH
        first = min(len(mask) - 1, int(round(start / FRAME)))
        pause = [k for k in range(first, max(-1, first - int(round(REACH / FRAME))), -1) if not mask[k]]
        start = max(0.0, (pause[0] + 1) * FRAME - MARGIN if pause else start - REACH)
    if end is not None:      # or its fading end: on to the next pause, within REACH
        first = int(round(end / FRAME))
        pause = [k for k in range(first, min(len(mask), first + int(round(REACH / FRAME)))) if not mask[k]]
        end = min(snd.duration, pause[0] * FRAME + MARGIN if pause else end + REACH)
    return (start or 0.0), (end if end is not None else snd.duration)


def said_at_the_end(first: Alignment, again: Alignment, end: float) -> bool:
    """Whether the words a new ``end`` moves are heard at the end of the
    clip after all: :data:`HEARD` of their phones matched, in order, by the
    last phones recognised there (twice as many)."""
    moved = [p for w in first.words if w.spoken and not w.recognized and w.end > end + SHIFT for p in w.phones]
    heard = [p for w in again.words if w.recognized and w.start >= end for p in w.phones][-2 * len(moved):]
    if not moved or not heard:
        return False
    return sum(same for _, _, same in edit_path(moved, heard)) >= HEARD * len(moved)
