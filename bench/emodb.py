"""Acted emotional German against hand labels (../shared/data/emodb; skips
when absent).

EmoDB's takes (five actors here, seven emotions: angry W, happy F, afraid
A, bored L, neutral N, sad T, disgusted E) carry hand-labelled phone
segmentations (``ID.lablaut``: each label's start in seconds; ``_x`` or
``x`` a stop's closure, ``!x`` its release, ``+x``/``-x`` diacritic marks,
``.`` the end; German SAMPA).  Each take is analysed with its sentence in
German (the words read through eSpeak NG, aligned with the English acoustic
model) and scored on:

* **boundaries**: the share of labelled segment starts (releases,
  aspiration and diacritics left out) with an aligned phone starting within
  20 ms and 40 ms of them;
* **lips closed**: the share of labelled /p b m/ (a stop from its closure to
  its release, a nasal to the next label) during which the lips close (the
  closure track 0.5 or more on a frame within 30 ms of it), and which of
  them are missed;
* **false alarms**: takes refused, words left unspoken, unscripted seconds,
  warnings (every transcript is right).

Printed per actor (the split: leave-one-actor-out of any constant tuned
here) and overall.

    .venv/bin/python bench/emodb.py
    .venv/bin/python bench/emodb.py --misses      # every /p b m/ the lips miss
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from common import need_data
from addon.engine import audio as audio_mod
from addon.engine.errors import LipSyncError
from addon.engine.pipeline import analyze
from addon.engine.settings import LineSettings

#: Labels that start no segment: a stop's release, aspiration, the end mark.
_NOT_SEGMENT = ("!", "+", "-", "*")


def labels(path: Path) -> list[tuple[float, str]]:
    """(start s, label) of every segment of an EmoDB label file, in order."""
    out = []
    for line in path.read_text(encoding="latin-1").split("#", 1)[1].splitlines():
        parts = line.split()
        if len(parts) >= 3 and parts[1] == "-1":
            out.append((float(parts[0]), parts[2]))
    return out


def segments(labs: list[tuple[float, str]]) -> list[tuple[str, float, float]]:
    """(label, start, end) of the segments: a stop's closure ends at its release, any segment at the
    next label's start."""
    out = []
    for k, (t, lab) in enumerate(labs):
        if lab.startswith(_NOT_SEGMENT) or lab == "." or lab.endswith("asp"):
            continue
        end = labs[k + 1][0] if k + 1 < len(labs) else t + 0.05
        out.append((lab.lstrip("_"), t, end))
    return out


def score(r, segs: list[tuple[str, float, float]]) -> tuple[list[float], list[tuple[str, float, bool]]]:
    """The distance (s) from each segment's start to the nearest aligned phone start, and for each
    labelled /p b m/ (label, start, lips closed)."""
    starts = np.array([p.start for p in r.alignment.phones]) if r.alignment.phones else np.array([np.inf])
    errors = [float(np.min(np.abs(starts - a))) for _, a, _ in segs]
    labial = []
    for lab, a, b in segs:
        if lab in ("p", "b", "m"):
            f = np.flatnonzero((r.times >= a - 0.03) & (r.times < b + 0.03))
            labial.append((lab, a, bool(len(f)) and float(r.closure[f].max()) >= 0.5))
    return errors, labial


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--misses", action="store_true", help="print every labelled /p b m/ the lips miss")
    args = ap.parse_args()
    data = need_data() / "emodb"
    takes = sorted(data.glob("*.wav"))
    settings = LineSettings.of(language="de")
    analyze(str(takes[0]), takes[0].with_suffix(".txt").read_text(encoding="utf-8"), settings)   # models loaded
    rows: dict[str, dict] = {}
    seconds = took = 0.0
    for wav in takes:
        actor = wav.stem[:2]
        row = rows.setdefault(actor, {"takes": 0, "errors": [], "labial": [], "refused": 0, "unspoken": 0,
                                      "unscripted": 0.0, "warned": 0})
        row["takes"] += 1
        text = wav.with_suffix(".txt").read_text(encoding="utf-8").strip()
        segs = segments(labels(wav.with_suffix(".lablaut")))
        snd = audio_mod.load(wav)
        t0 = time.perf_counter()
        try:
            r = analyze(snd, text, settings)
        except LipSyncError as exc:
            row["refused"] += 1
            print(f"  {wav.stem}: refused: {exc}")
            continue
        took += time.perf_counter() - t0
        seconds += snd.duration
        errors, labial = score(r, segs)
        row["errors"] += errors
        row["labial"] += labial
        al = r.alignment
        row["unspoken"] += sum(not w.spoken for w in al.script)
        row["unscripted"] += sum(b - a for a, b, _ in al.unscripted)
        row["warned"] += bool(r.warnings)
        if args.misses:
            for lab, a, closed in labial:
                if not closed:
                    print(f"  {wav.stem} {text!r}: /{lab}/ at {a:.3f} s open; aligned: "
                          + " ".join(f"{p.phone}@{p.start:.2f}" for p in al.phones if abs(p.start - a) < 0.15))
    print(f"EmoDB: {len(takes)} takes by {len(rows)} actors, German, analysed in {took / max(seconds, 1e-9):.3f} x "
          "real time")
    print(f"  {'actor':8s} {'takes':>5s} {'<=20ms':>7s} {'<=40ms':>7s} {'pbm':>4s} {'closed':>7s} "
          f"{'refused':>7s} {'unspoken':>8s} {'unscr s':>7s} {'warned':>6s}")
    for actor in sorted(rows) + ["all"]:
        g = list(rows.values()) if actor == "all" else [rows[actor]]
        err = np.array([e for x in g for e in x["errors"]])
        lab = [closed for x in g for _, _, closed in x["labial"]]
        total = {key: sum(x[key] for x in g) for key in ("takes", "refused", "unspoken", "unscripted", "warned")}
        print(f"  {actor:8s} {total['takes']:5d} {np.mean(err <= 0.02):7.3f} {np.mean(err <= 0.04):7.3f} "
              f"{len(lab):4d} {np.mean(lab):7.3f} {total['refused']:7d} {total['unspoken']:8d} "
              f"{total['unscripted']:7.1f} {total['warned']:6d}")


if __name__ == "__main__":
    main()
