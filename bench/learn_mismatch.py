"""Learning from captures of a model that is not ours: does the learned
preset move the mouth more like the capture on lines it has not seen?

The captures are synthetic (tests/mismatch.py): hand-made articulatory
targets per phoneme (jaw, lip aperture, rounding) tracked by a critically
damped system with class-dependent stiffness, i.e. a different blending law
from the dominance model; delayed by 30 or 60 ms, scaled and offset into a
sensor's units, with noise.  Four sentences of the project's own speech at
two speaking rates make 8 clips; each is held out in turn (leave-one-clip-
out) and predicted by a preset learned from the other 7, against the
starting preset (neutral).  Prints per held-out clip and track: correlation,
RMSE and peak-timing error, learned vs start; the means; the delay found.
No recordings are needed.

    .venv/bin/python bench/learn_mismatch.py [--delay-ms 30 60]
"""

from __future__ import annotations

import argparse
import time

from common import ROOT
from addon.engine import learning

import sys
sys.path.insert(0, str(ROOT / "tests"))
import mismatch


def per_track_change(r: dict) -> str:
    """Learned minus start per track on the held-out clips, and whether any
    track is worse beyond noise (correlation -0.01, RMSE +0.5 %)."""
    out, worse = [], []
    for ch in r["channels"]:
        t = r["per_track"][ch]
        lc, sc = t["learned"]["correlation"], t["start"]["correlation"]
        dc = None if lc is None or sc is None else lc - sc
        rel = t["learned"]["rmse"] / t["start"]["rmse"] - 1 if t["start"]["rmse"] > 0 else 0.0
        out.append(f"{ch} r {'-' if dc is None else f'{dc:+.3f}'} RMSE {100 * rel:+.1f} %")
        if (dc is not None and dc < -0.01) or rel > 0.005:
            worse.append(ch)
    return ("learned - start: " + "; ".join(out) + "; worse beyond noise: " + (", ".join(worse) or "none"))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--delay-ms", type=float, nargs="+", default=[30.0, 60.0])
    ap.add_argument("--emotion", default="neutral")
    args = ap.parse_args()
    for d in args.delay_ms:
        clips = mismatch.clips(rates=(0.9, 1.15), delay=d / 1000.0)
        t0 = time.perf_counter()
        result = learning.learn(clips, emotion=args.emotion, viseme_set="arkit", name="mismatch")
        r = result.report
        print(f"== capture delay {d:.0f} ms: {len(clips)} clips, learned in {time.perf_counter() - t0:.1f} s; "
              f"delay found {r['delay_ms']:.1f} ms (error {r['delay_ms'] - d:+.1f} ms)")
        print(learning.summary_text(r))
        print(per_track_change(r))
        print()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
