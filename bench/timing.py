"""Timing of the mouth against reference phones, ours and Rhubarb's in one run.

Reads the clips with reference phone tiers in ../shared/data (skips when the
folder is absent): three hand-labelled praatio sentences and the two ~26 s
MFA clips (aligner references).  Each clip is analysed by the engine
(in-process, 100 fps, dominance model, neutral preset, default viseme set)
and by Rhubarb Lip Sync 1.13 (a fresh process given the transcript with
``-d``; fetched into ``.tools/`` by ``rhubarb_compare.py``'s
``ensure_rhubarb``).  Both outputs are read on the same 10 ms frame grid: a
frame's value is the output at the frame's centre.

The figures, per clip and over all clips:

``start<=40`` / ``median``  Phone-start error (ours only; Rhubarb emits
    mouth shapes, not phones).  Aligned phones are matched to reference
    phones in order (edit-distance path of the two ARPAbet strings, as in
    ``alignment_accuracy.py``); the error of a matched phone is
    ``|our start - reference start|`` rounded to 0.1 ms; the share within
    40 ms and the median are printed.

``rest``  Rest share in reference pauses: the reference pauses are the
    stretches between two reference phones with no phone in them (silence
    labels or gaps) lasting 0.3 s or more; the mouth may leave rest and come
    back within 40 ms of either end (the tolerance of the phone starts), so
    the frames of the pause more than 40 ms from its ends are scored, and the
    figure is the share of them on which the output shows the mouth at rest.
    Leading and trailing silence is not a pause.  Nor is a gap that must hold
    a word the reference's word tier leaves out: when the transcript has a
    word between two words the reference has, and the reference has none
    there (acoustic_corpus: its "uh" at 14.5 s, which the speaker says), the
    pauses between those two reference words are spoken, so they are not
    scored, for ours or for Rhubarb; the run prints them.

``closed-V``  False closures: the share of reference vowel frames (10 ms
    frames whose centre lies inside a reference vowel) on which the output
    shows closed lips.

``pbm``  Closure recall: the share of reference /p b m/ phones with at least
    one frame inside them on which the output shows closed lips.

How the two outputs are read:

* ours: *rest* when every viseme curve is at most 0.2 (the default set's
  silence is no viseme at all) and the closure track is below 0.5;
  *closed* when the closure track (the lips-closed channel a rig applies) is
  at least 0.5, or the MBP viseme is at least 0.5 and the largest viseme.
* Rhubarb: *rest* is shape X (idle), *closed* is shape A (closed lips).

    .venv/bin/python bench/timing.py            # ours and Rhubarb
    .venv/bin/python bench/timing.py --no-rhubarb
    .venv/bin/python bench/timing.py --no-transcript  # both recognise the words

With ``--no-transcript`` neither is given the words: ours recognises them,
Rhubarb runs without ``-d``.  The rest, false-closure and closure figures
are read as above; phone starts are matched to the reference all the same
(recognised phones differ, so that figure says less).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from common import match, reference_phones, write_wav
from addon.engine import audio as audio_mod
from addon.engine import pipeline
from addon.engine.importers import read_textgrid
from addon.engine.language.phonemes import is_vowel
from addon.engine.language.text import normalize
from addon.engine.settings import LineSettings

STEP = 0.01
MIN_PAUSE = 0.3
EDGE = 0.04
REST_MAX = 0.2
CLOSED_MIN = 0.5


def grid(duration: float) -> np.ndarray:
    return (np.arange(int(np.floor(duration / STEP))) + 0.5) * STEP


def reference_pauses(phones) -> list[tuple[float, float]]:
    out = []
    for a, b in zip(phones[:-1], phones[1:]):
        if b.start - a.end >= MIN_PAUSE - 1e-6:
            out.append((a.end, b.start))
    return out


def unlabelled_words(text: str, ref) -> list[tuple[str, float, float]]:
    """Transcript words the reference's word tier leaves out, each with the
    stretch it must lie in: from the end of the reference word matched
    before it to the start of the one matched after, when the reference has
    no word between those two (a word spelt differently is not left out)."""
    said = [w.text.lower() for w in normalize(text)]
    labelled = [w.text.lower() for w in ref.words]
    pairs = match(said, labelled)
    out = []
    for (i0, j0), (i1, j1) in zip([(-1, -1)] + pairs, pairs + [(len(said), len(labelled))]):
        if i1 - i0 > 1 and j1 == j0 + 1:
            lo = ref.words[j0].end if j0 >= 0 else 0.0
            hi = ref.words[j1].start if j1 < len(labelled) else ref.duration
            out.extend((said[i], lo, hi) for i in range(i0 + 1, i1))
    return out


def scored_pauses(ref, unlabelled) -> list[tuple[float, float]]:
    """The reference pauses, less those inside a stretch that holds a
    transcript word the reference left out."""
    return [(a, b) for a, b in reference_pauses(ref.phones)
            if not any(lo - 1e-6 <= a and b <= hi + 1e-6 for _, lo, hi in unlabelled)]


def our_states(result, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rest, closed) per frame of ``t`` from an analysis result."""
    curves = np.stack([np.interp(t, result.times, c) for c in result.curves.T], axis=1)
    closure = np.interp(t, result.times, result.closure) if len(result.closure) else np.zeros(len(t))
    mbp = result.viseme_set.index(result.viseme_set.of("M")[0])
    rest = (curves.max(axis=1) <= REST_MAX) & (closure < CLOSED_MIN)
    closed = (closure >= CLOSED_MIN) | ((curves[:, mbp] >= CLOSED_MIN) & (curves.argmax(axis=1) == mbp))
    return rest, closed


def rhubarb_states(cues: list[dict], t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    shape = np.full(len(t), "X", dtype=object)
    for c in cues:
        shape[(t >= c["start"]) & (t < c["end"])] = c["value"]
    return shape == "X", shape == "A"


def scores(rest: np.ndarray, closed: np.ndarray, t: np.ndarray, ref, pauses) -> dict:
    """Counts for the rest (in ``pauses``), false-closure and closure-recall figures."""
    pause = np.zeros(len(t), bool)
    for a, b in pauses:
        pause |= (t >= a + EDGE) & (t < b - EDGE)
    vowel = np.zeros(len(t), bool)
    pbm_hit = pbm_n = 0
    for p in ref.phones:
        inside = (t >= p.start) & (t < p.end)
        if is_vowel(p.phone):
            vowel |= inside
        elif p.phone in ("P", "B", "M"):
            pbm_n += 1
            if not inside.any():   # shorter than a frame: the frame nearest its centre
                inside = np.abs(t - (p.start + p.end) / 2) == np.abs(t - (p.start + p.end) / 2).min()
            pbm_hit += bool(closed[inside].any())
    return {"pause_n": int(pause.sum()), "pause_rest": int((rest & pause).sum()),
            "vowel_n": int(vowel.sum()), "vowel_closed": int((closed & vowel).sum()),
            "pbm_n": pbm_n, "pbm_hit": pbm_hit}


def fmt(c: dict) -> str:
    rest = f"{c['pause_rest'] / c['pause_n']:6.1%}" if c["pause_n"] else f"{'-':>6s}"
    fc = f"{c['vowel_closed'] / c['vowel_n']:6.2%}" if c["vowel_n"] else f"{'-':>6s}"
    pbm = f"{c['pbm_hit'] / c['pbm_n']:5.2f}" if c["pbm_n"] else f"{'-':>5s}"
    return f"{rest} {fc} {pbm}"


def add(total: dict, c: dict) -> None:
    for k, v in c.items():
        total[k] = total.get(k, 0) + v


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--no-rhubarb", action="store_true", help="score our output only")
    ap.add_argument("--clips", nargs="*", help="only these clips")
    ap.add_argument("--no-transcript", action="store_true", help="neither is given the words")
    args = ap.parse_args(argv)
    clips = reference_phones()
    if args.clips:
        clips = [c for c in clips if c[0] in args.clips]
    rhubarb = None
    if not args.no_rhubarb:
        from rhubarb_compare import ensure_rhubarb
        rhubarb = ensure_rhubarb()
    tmp = Path(tempfile.mkdtemp())
    print(f"{'clip':16s} {'pauses':>6s} {'start<=40':>9s} {'median':>7s} | {'ours: rest':>10s} {'closed-V':>8s} "
          f"{'pbm':>5s} | {'rhubarb: rest':>13s} {'closed-V':>8s} {'pbm':>5s} | {'ours s':>6s}")
    all_err: list[float] = []
    left_out: list[str] = []
    tot_o: dict = {}
    tot_r: dict = {}
    for name, audio, text, grid_path, phoneset in clips:
        ref = read_textgrid(grid_path, phoneset)
        snd = audio_mod.load(audio)
        t = grid(snd.duration)
        t0 = time.perf_counter()
        res = pipeline.analyze(snd, None if args.no_transcript else text, LineSettings.of(fps=100))
        dt = time.perf_counter() - t0
        al = res.alignment
        pairs = match([p.phone for p in al.phones], [p.phone for p in ref.phones])
        err = np.round(np.array([abs(al.phones[i].start - ref.phones[j].start) for i, j in pairs]), 4)
        all_err.extend(err)
        unlabelled = unlabelled_words(text, ref)
        pauses = scored_pauses(ref, unlabelled)
        left_out += [f"{name} {w!r} between {lo:.2f} and {hi:.2f} s" for w, lo, hi in unlabelled]
        co = scores(*our_states(res, t), t, ref, pauses)
        add(tot_o, co)
        line = (f"{name:16s} {len(pauses):6d} {np.mean(err <= 0.04):9.1%} "
                f"{np.median(err) * 1000:5.1f}ms | {fmt(co):>25s} | ")
        if rhubarb is not None:
            wav, txt, out = tmp / f"{name}.wav", tmp / f"{name}.txt", tmp / f"{name}.json"
            write_wav(wav, snd.samples, snd.rate)
            txt.write_text(text, encoding="utf-8")
            given = [] if args.no_transcript else ["-d", str(txt)]
            subprocess.run([str(rhubarb), "-q", "-f", "json", *given, "-o", str(out), str(wav)],
                           check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            cues = json.loads(out.read_text(encoding="utf-8"))["mouthCues"]
            cr = scores(*rhubarb_states(cues, t), t, ref, pauses)
            add(tot_r, cr)
            line += f"{fmt(cr):>28s} | "
        else:
            line += f"{'':28s} | "
        print(line + f"{dt:6.2f}")
    e = np.array(all_err)
    line = (f"{'[all]':16s} {'':6s} {np.mean(e <= 0.04):9.1%} {np.median(e) * 1000:5.1f}ms | {fmt(tot_o):>25s} | ")
    line += f"{fmt(tot_r):>28s} |" if tot_r else ""
    print(line)
    for w in left_out:
        print(f"not in the reference's words, so the pauses there are not scored: {w}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
