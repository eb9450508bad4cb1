"""Every clip with a transcript in ../shared/data aligned, every word placed.

Prints per clip the words, phonemes, how many were placed by the documented
fallback (estimated) and the time taken.  Skips when the folder is absent.

    .venv/bin/python bench/coverage.py
"""

from __future__ import annotations

import time

from common import transcript_clips
from addon.engine.errors import LipSyncError
from addon.engine.pipeline import analyze


def main():
    total_p = total_e = failed = 0
    for name, audio, text in transcript_clips():
        t0 = time.perf_counter()
        try:
            r = analyze(audio, text)
        except LipSyncError as exc:
            failed += 1
            print(f"{name:26s} ERROR {exc}")
            continue
        al = r.alignment
        total_p += len(al.phones)
        total_e += al.n_estimated
        print(f"{name:26s} {len(al.words):4d} words {len(al.phones):4d} phonemes {al.n_estimated:4d} estimated "
              f"{r.duration:6.1f} s audio {time.perf_counter() - t0:5.2f} s")
    print(f"total: {total_p} phonemes, {total_e} estimated ({total_e / max(total_p, 1):.1%}), "
          f"{failed} clip(s) with an error")


if __name__ == "__main__":
    main()
