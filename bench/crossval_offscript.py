"""Leave-one-clip-out figures of the recogniser's language-model weight (speech with no transcript).

``alignment/recognize.py`` ``DECODER_OPTIONS`` sets ``lw`` (how much the language model weighs
against the sounds) to 4 where pocketsphinx's default is 6.5; it was chosen on the five clips of
``bench/offscript.py``'s first table (the event score without a transcript), the clips that also
judge it.  This bench says what that choice is worth on a clip it did not see.  It changes nothing
in the engine: ``lw`` is set in-process, and set back, for the bench's own runs.

Reads ``../shared/data`` (skips cleanly without it): the clips with reference phones
(``bench/common.py`` ``reference_phones``: three praatio sentences and the two 26 s MFA clips).  For
each ``lw`` of the grid every clip is recognised and animated with no transcript (``analyze(snd,
None)``, the recogniser's models loaded again for that ``lw``) and scored as ``bench/offscript.py``
scores it: the event score (the share of the reference's vowels shown open, /p b m/ shown closed and
pauses of 0.3 s shown at rest) and the share of reference phones whose start is matched within 40 ms.

Printed: both figures per clip and ``lw`` (with their mean over the clips and over the events), then
the choice made on all five clips (in-sample: the ``lw`` with the best mean event score over the
clips, ``bench/offscript.py``'s headline), and leave one clip out: for each clip, the ``lw`` with the
best mean over the other four, scored on that clip (a tie: the mean of the tied ``lw`` s' scores),
pooled over the five clips and over their events.

    .venv/bin/python bench/crossval_offscript.py                  # about 2 minutes (2 cores)
    .venv/bin/python bench/crossval_offscript.py --lw 3 4 5 6.5
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from common import need_data, reference_phones
from offscript import event_score, phone_starts

from addon.engine import audio as audio_mod
from addon.engine.alignment import recognize
from addon.engine.importers import read_textgrid
from addon.engine.pipeline import analyze

GRID = (2.0, 3.0, 4.0, 5.0, 6.5, 8.0)


def measure(clips, lws) -> dict:
    """{(lw, clip): (events hit, events, starts within 40 ms, words heard)}."""
    saved = dict(recognize.DECODER_OPTIONS)
    out = {}
    try:
        for lw in lws:
            recognize.DECODER_OPTIONS["lw"] = lw
            recognize._loaded.clear()
            t0 = time.perf_counter()
            for name, snd, ref in clips:
                r = analyze(snd, None)
                share, n = event_score(r, ref)
                out[lw, name] = (int(round(share * n)), n, phone_starts(r, ref),
                                 " ".join(w.text for w in r.alignment.words))
            spent = time.perf_counter() - t0
            print(f"  lw {lw:g}: {spent:.0f} s, {spent / sum(snd.duration for _, snd, _ in clips):.2f} x real time "
                  "(models loaded included)", flush=True)
    finally:
        recognize.DECODER_OPTIONS.clear()
        recognize.DECODER_OPTIONS.update(saved)
        recognize._loaded.clear()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lw", type=float, nargs="+", default=list(GRID), help="language-model weights to try")
    args = ap.parse_args()
    need_data()
    t0 = time.perf_counter()
    clips = [(name, audio_mod.load(audio), read_textgrid(grid, phoneset))
             for name, audio, _text, grid, phoneset in reference_phones()]
    names = [c[0] for c in clips]
    shipped = recognize.DECODER_OPTIONS["lw"]
    lws = sorted(set(args.lw) | {shipped})
    got = measure(clips, lws)

    def score(lw, name):
        hit, n, _, _ = got[lw, name]
        return hit / n

    def by_clip(lw, which):
        return float(np.mean([score(lw, c) for c in which]))

    def by_event(lw, which):
        return sum(got[lw, c][0] for c in which) / sum(got[lw, c][1] for c in which)

    print(f"\nNo transcript: event score per clip and language-model weight (lw; shipped {shipped:g}, "
          "pocketsphinx's default 6.5)")
    print(f"{'clip':16s} {'events':>6s} " + " ".join(f"{'lw ' + format(lw, 'g'):>7s}" for lw in lws))
    for c in names:
        print(f"{c:16s} {got[lws[0], c][1]:6d} " + " ".join(f"{score(lw, c):7.3f}" for lw in lws))
    print(f"{'mean (by clip)':16s} {'':6s} " + " ".join(f"{by_clip(lw, names):7.3f}" for lw in lws))
    print(f"{'mean (by event)':16s} {'':6s} " + " ".join(f"{by_event(lw, names):7.3f}" for lw in lws))
    print("\nphone starts within 40 ms of the reference (share of reference phones)")
    for c in names:
        print(f"{c:16s} {'':6s} " + " ".join(f"{got[lw, c][2]:7.3f}" for lw in lws))
    print(f"{'mean (by clip)':16s} {'':6s} " + " ".join(f"{np.mean([got[lw, c][2] for c in names]):7.3f}"
                                                        for lw in lws))

    best = max(by_clip(lw, names) for lw in lws)
    chosen = [lw for lw in lws if by_clip(lw, names) == best]
    print(f"\nin-sample (chosen on all 5 clips by the mean event score over the clips): lw "
          f"{', '.join(format(lw, 'g') for lw in chosen)}: {best:.3f} by clip, "
          f"{np.mean([by_event(lw, names) for lw in chosen]):.3f} by event; shipped lw {shipped:g}: "
          f"{by_clip(shipped, names):.3f} by clip, {by_event(shipped, names):.3f} by event")
    print("leave one clip out (lw chosen on the other four, the held clip scored with it):")
    held, hits, events = [], 0.0, 0
    for c in names:
        rest = [x for x in names if x != c]
        top = max(by_clip(lw, rest) for lw in lws)
        tied = [lw for lw in lws if by_clip(lw, rest) == top]
        s = float(np.mean([score(lw, c) for lw in tied]))
        held.append(s)
        hits += float(np.mean([got[lw, c][0] for lw in tied]))
        events += got[lws[0], c][1]
        print(f"  {c:16s} lw {', '.join(format(lw, 'g') for lw in tied):12s} (others {top:.3f}) held-out "
              f"{s:.3f}; with lw {shipped:g} {score(shipped, c):.3f}")
    print(f"leave one clip out, pooled: {np.mean(held):.3f} by clip, {hits / events:.3f} by event "
          f"(in-sample {best:.3f} / shipped {by_clip(shipped, names):.3f} by clip)")
    print("\nwords heard with no transcript, per lw (the first 60 characters)")
    for c in names:
        for lw in lws:
            print(f"  {c:16s} lw {lw:<4g} {got[lw, c][3][:60]}")
    print(f"\ntotal {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
