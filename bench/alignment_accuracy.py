"""Alignment accuracy against reference phone boundaries.

Reads the recordings in ../shared/data (skips when absent).  For each clip
with a reference phone tier, aligns the transcript to the audio and matches
aligned phones to reference phones in order (edit-distance alignment of the two
phone strings), then reports the share of phone starts within 20 ms and 40 ms
of the reference and the median start error.  Errors are rounded to 0.1 ms
before they are compared: the aligner's times lie on a 10 ms frame grid, and
a start 40 ms from the reference must not count as a miss because
1.50 - 1.54 is 0.04000000000000004 in floating point.

The two MFA clips are also joined into one ~52 s clip (acoustic, then cold)
and scored against their references shifted accordingly: clips that long are
cut into more pieces (eight) than the ~26 s clips (four).
Joined twice over (~105 s), they are aligned window by window, the path of
long recordings.

    .venv/bin/python bench/alignment_accuracy.py
"""

from __future__ import annotations

import time

import numpy as np

from common import match, reference_phones
from addon.engine.alignment import align_audio, align_file
from addon.engine.importers import read_textgrid


def joined_row(repeat: int = 1) -> None:
    """Both MFA clips as one clip (``repeat`` times over), scored against
    both references."""
    from addon.engine import audio as audio_mod

    clips = [c for c in reference_phones() if c[0].endswith("corpus")] * repeat
    sounds = [audio_mod.load(c[1]) for c in clips]
    joined = audio_mod.Audio(np.concatenate([s.samples for s in sounds]), sounds[0].rate)
    text = " ".join(c[2] for c in clips)
    ref_phones, offset = [], 0.0
    for c, s in zip(clips, sounds):
        ref_phones += [(p.phone, p.start + offset) for p in read_textgrid(c[3], c[4]).phones]
        offset += s.duration
    t0 = time.perf_counter()
    al = align_audio(joined, text)
    dt = time.perf_counter() - t0
    pairs = match([p.phone for p in al.phones], [p[0] for p in ref_phones])
    err = np.round(np.array([abs(al.phones[i].start - ref_phones[j][1]) for i, j in pairs]), 4)
    name = "mfa joined" + (f" x{repeat}" if repeat > 1 else "")
    print(f"{name:18s} {len(ref_phones):6d} {len(pairs):7d} {np.mean(err <= 0.02):7.1%} "
          f"{np.mean(err <= 0.04):7.1%} {np.median(err) * 1000:6.1f}ms {al.n_estimated:5d} {dt:5.2f}s")


def main() -> None:
    print(f"{'clip':18s} {'phones':>6s} {'matched':>7s} {'<=20ms':>7s} {'<=40ms':>7s} {'median':>8s} "
          f"{'est.':>5s} {'time':>6s}")
    groups: dict[str, list[float]] = {"mfa": [], "praatio": [], "all": []}
    for name, audio, text, grid, phoneset in reference_phones():
        ref = read_textgrid(grid, phoneset)
        t0 = time.perf_counter()
        al = align_file(audio, text)
        dt = time.perf_counter() - t0
        hyp = [p.phone for p in al.phones]
        pairs = match(hyp, [p.phone for p in ref.phones])
        err = np.round(np.array([abs(al.phones[i].start - ref.phones[j].start) for i, j in pairs]), 4)
        group = "mfa" if name.endswith("corpus") else "praatio"
        groups[group].extend(err)
        groups["all"].extend(err)
        print(f"{name:18s} {len(ref.phones):6d} {len(pairs):7d} {np.mean(err <= 0.02):7.1%} "
              f"{np.mean(err <= 0.04):7.1%} {np.median(err) * 1000:6.1f}ms {al.n_estimated:5d} {dt:5.2f}s")
    joined_row()
    joined_row(2)
    for g, e in groups.items():
        e = np.array(e)
        print(f"{'[' + g + ']':18s} {'':6s} {len(e):7d} {np.mean(e <= 0.02):7.1%} {np.mean(e <= 0.04):7.1%} "
              f"{np.median(e) * 1000:6.1f}ms")


if __name__ == "__main__":
    main()
