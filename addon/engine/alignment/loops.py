"""Phone loops in a word pass: speech the transcript's words do not hold.

A loop of any phones (each a one-phone word ``x<phone>``), penalised phone
by phone, takes in a word pass only the speech the words do not fit: speech
before or after the script and speech cut from it (:mod:`.edges`), or the
speech of a word a wrong one stands in for (:mod:`.room`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

from ..audio import Audio
from .decoding import _decoder
from .fillers import base_token
from .model import FRAME, AlignSettings

#: The acoustic model's speech phones, each a one-phone word of the loop.
LOOP_PHONES = ("AA AE AH AO AW AY B CH D DH EH ER EY F G HH IH IY JH K L M N NG OW OY P R S SH T TH UH UW "
               "V W Y Z ZH").split()
#: The grammar's weight of a loop where one may come (against 1 - it of none, or of the word).
LOOP_WEIGHT = 0.1
#: The word insertion penalty of the pass: each phone of a loop costs this much, so a loop takes
#: only speech the words do not fit (pocketsphinx's 0.65 let it take the last words of a line
#: whose middle had been cut from the transcript, with their own speech).  Every word pays it too,
#: scaled by the language weight, and a loop scores better than words on any speech: on a long,
#: hard take (a hoarse voice) the words' path can fall out of the beam, and the pass find none.
PHONE_PENALTY = 1e-3


def loop_pass(audio: Audio, prons: Sequence[Sequence[str]], first: int, gaps: set[int], settings: AlignSettings,
              t0: float = 0.0, t1: float | None = None, beam: float | None = None, one: bool = False,
              penalty: float = PHONE_PENALTY, instead: frozenset[int] = frozenset(), weight: float = LOOP_WEIGHT
              ) -> list[tuple[str, float, float]] | None:
    """One word pass over ``audio`` t0..t1 (s) through the words ``prons``
    (tokens ``w<first>``...), in order, where a loop of any phones may come
    before word ``k`` for every ``k`` in ``gaps`` (``len(prons)``: after the
    last); with ``one``, a loop comes at exactly one of them.  Each word
    ``k`` in ``instead`` may be a loop instead (the grammar's weight of
    the loop ``weight``, of the word 1 - it).  Returns the (word, start s,
    end s) segments, loop phones as ``x<phone>``; None when the pass finds
    no path.  ``beam`` (all three beams) narrows the search: each loop is a
    copy of every phone."""
    t1 = audio.duration if t1 is None else t1
    loop = "( " + " | ".join(f"x{p}" for p in LOOP_PHONES) + " )"
    maybe = f"( /{1 - LOOP_WEIGHT}/ <NULL> | /{LOOP_WEIGHT}/ <loop> )"
    words = [f"( /{1 - weight}/ w{first + k} | /{weight}/ <loop> )" if k in instead else f"w{first + k}"
             for k in range(len(prons))] + [""]
    if one:
        body = "( " + " | ".join(" ".join(words[:k] + ["<loop>"] + words[k:]).strip() for k in sorted(gaps)) + " )"
    else:
        body = " ".join(part for k, w in enumerate(words) for part in ([maybe] if k in gaps else []) + [w] if part)
    grammar = f"#JSGF V1.0;\ngrammar loops;\n<loop> = {loop}+;\npublic <s> = {body};\n"
    if beam:
        settings = replace(settings, beam=beam, pbeam=beam, wbeam=beam)
    try:
        # Each word as written: the pass looks for speech the words do not hold, and a word's other
        # pronunciations (.model.Variants) would let it take some of that speech.
        decoder = _decoder([list(p) for p in prons], first, settings, more=[f"x{p} {p}" for p in LOOP_PHONES],
                           wip=penalty)
        decoder.add_jsgf_string("loops", grammar)
        decoder.activate_search("loops")
        decoder.start_utt()
        decoder.process_raw(audio.pcm16(t0, t1), full_utt=True)
        decoder.end_utt()
        segs = [(sg.word, t0 + sg.start_frame * FRAME, t0 + (sg.end_frame + 1) * FRAME)
                for sg in (decoder.seg() or [])]
    except RuntimeError:
        return None
    tokens = [f"w{first + k}" for k in range(len(prons))]
    found = [base_token(w) for w, _, _ in segs if base_token(w) in set(tokens)]
    if found != [t for k, t in enumerate(tokens) if k not in instead or t in found]:
        return None
    return segs


def loops(segs: list[tuple[str, float, float]]) -> list[tuple[float, float]]:
    """The (start, end) s of the runs of loop phones in a :func:`loop_pass`'s segments."""
    out: list[list[float]] = []
    inside = False
    for w, a, b in segs:
        if w.startswith("x"):
            if inside:
                out[-1][1] = b
            else:
                out.append([a, b])
            inside = True
        elif base_token(w).startswith("w"):
            inside = False
    return [(a, b) for a, b in out]
