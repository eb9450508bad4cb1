"""Where a line's time goes beyond its first alignment: the cost of every
pass the checks of a take against its script (and the aligner's second
looks) make, clip by clip, on real recordings (../shared/data; skips when
absent).

Every English clip with a transcript and TIMIT's 61 sentences (the clips
``bench/speed.py --against`` times, bench/common.py ``timed_clips``) is analysed in-process with its right transcript,
the models loaded (a first run each), best of 3; the time of each pass is
summed over the run that was fastest:

* ``held``: a vowel held for seconds next to speech left off the words,
  the line aligned again with the vowel free (:mod:`.held`);
* ``slowed``: a line too fast for the aligner's frames aligned again on a
  slowed copy (:mod:`.tempo`);
* ``verify``: words not heard, speech not in the transcript (:mod:`.verify`);
* ``edges``, ``left out``: speech before or after the script, speech cut
  from between its words (:mod:`.edges`);
* ``room``: words longer than the speech they stand for (:mod:`.room`);
* ``realigned``: the line aligned again after one of those found something
  (``first``: its first alignment, for scale);
* ``refine``: the boundary model (:mod:`.refine`);
* ``recognised``: of ``verify``, ``edges`` and ``left out``, the time spent
  recognising stretches of speech to count their words.

It prints the clips on which those passes take at least ``--share`` of
``analyze`` (default 0.1) with each pass's seconds ("-": not made), then
the share of all the clips' time the passes take (a pass made inside
another, and recognition, counted once).  A right
transcript has no words missing and no speech beyond it, so every second
here is a pass made on evidence that turned out to be nothing, or a second
look that improved the line (``held`` and ``slowed`` keep the better
alignment).

    .venv/bin/python bench/check_cost.py
    .venv/bin/python bench/check_cost.py --clips mfa_ corpus --share 0
"""

from __future__ import annotations

import argparse
import time
from collections import defaultdict
from contextlib import contextmanager

from common import need_data, timed_clips
from addon.engine import audio as audio_mod
from addon.engine.alignment import tempo, transcript, verify
from addon.engine.pipeline import analyze

#: The passes timed, as (label, module, function name); the transcript module calls each by that name.
PASSES = (("held", transcript, "said_otherwise"), ("verify", transcript, "verify"),
          ("edges", transcript, "edges"), ("left out", transcript, "left_out"), ("room", transcript, "room"),
          ("refine", transcript, "refine_alignment"),
          ("recognised", verify, "recognize_spans"))
COLUMNS = ("first", "held", "slowed", "verify", "edges", "left out", "room", "realigned", "refine", "recognised")


@contextmanager
def timed(spent: dict[str, float], found: dict[str, int]):
    """Every pass of :data:`PASSES` (and the slowed copy's alignment) adds its
    seconds to ``spent`` and counts its calls in ``found`` while inside; a
    pass made inside another counts in both, and ``spent["all"]`` holds the
    outermost passes' time, each second once."""
    saved = []
    depth = [0]

    def wrap(label, module, name):
        fn = getattr(module, name)
        saved.append((module, name, fn))

        def timed_fn(*args, **kwargs):
            t0 = time.perf_counter()
            depth[0] += 1
            try:
                return fn(*args, **kwargs)
            finally:
                depth[0] -= 1
                dt = time.perf_counter() - t0
                spent[label] += dt
                found[label] += 1
                if not depth[0]:
                    spent["all"] += dt
        setattr(module, name, timed_fn)

    for label, module, name in PASSES:
        wrap(label, module, name)
    # Alignments: the first one, and those made again outside the passes above.
    align = transcript.align
    saved.append((transcript, "align", align))

    def align_fn(*args, **kwargs):
        t0 = time.perf_counter()
        try:
            return align(*args, **kwargs)
        finally:
            dt = time.perf_counter() - t0
            label = "first" if not found["first"] else "realigned" if not depth[0] else None
            if label:
                spent[label] += dt
                found[label] += 1
                if label == "realigned":
                    spent["all"] += dt
    transcript.align = align_fn
    # The slowed copy: from the copy being made to the choice of the better alignment.
    slowed, better = tempo.slowed, tempo.better
    started: list[float] = []

    def slowed_fn(*args, **kwargs):
        started.append((time.perf_counter(), depth[0]))
        depth[0] += 1
        return slowed(*args, **kwargs)

    def better_fn(first, slow):
        t0, at = started.pop()
        depth[0] -= 1
        dt = time.perf_counter() - t0
        spent["slowed"] += dt
        found["slowed"] += 1
        if not at:
            spent["all"] += dt
        return better(first, slow)

    saved += [(tempo, "slowed", slowed), (tempo, "better", better)]
    tempo.slowed, tempo.better = slowed_fn, better_fn
    try:
        yield
    finally:
        for module, name, fn in saved:
            setattr(module, name, fn)


def clips(only: list[str] | None) -> list[tuple[str, str, str]]:
    return [(name, str(path), text) for name, path, text in timed_clips()
            if not only or any(o in name for o in only)]


def measure(path: str, text: str) -> tuple[float, float, dict[str, float], dict[str, int]]:
    """(audio s, best analyze s, seconds per pass, calls per pass) of one clip."""
    snd = audio_mod.load(path)
    analyze(snd, text)
    best = None
    for _ in range(3):
        spent: dict[str, float] = defaultdict(float)
        found: dict[str, int] = defaultdict(int)
        with timed(spent, found):
            t0 = time.perf_counter()
            analyze(snd, text)
            took = time.perf_counter() - t0
        if best is None or took < best[0]:
            best = (took, spent, found)
    return snd.duration, best[0], best[1], best[2]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--clips", nargs="*", help="only the clips whose name holds one of these")
    ap.add_argument("--share", type=float, default=0.1, help="print the clips whose passes take this share or more")
    args = ap.parse_args()
    need_data()
    print(f"{'clip':26s} {'audio s':>7s} {'x rt':>6s} {'passes':>6s} " + " ".join(f"{c:>10s}" for c in COLUMNS))
    total = passes = 0.0
    for name, path, text in clips(args.clips):
        seconds, took, spent, found = measure(path, text)
        extra = spent["all"]
        total += took
        passes += extra
        if extra / took >= args.share:
            cells = " ".join(f"{spent[c]:10.3f}" if found[c] else f"{'-':>10s}" for c in COLUMNS)
            print(f"{name:26s} {seconds:7.1f} {took / seconds:6.3f} {extra / took:6.0%} {cells}", flush=True)
    print(f"all clips: the passes take {passes:.2f} s of {total:.2f} s of analyze ({passes / max(total, 1e-9):.0%})")


if __name__ == "__main__":
    main()
