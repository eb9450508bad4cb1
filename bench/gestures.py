"""The gesture layer on real lines (../shared/data; skips when absent): the
blink rate and length, blinks at pauses, the gaze's shifts and range, and
the head's motion against the voice, as the acceptance checks measure them.

Every clip with a transcript (bench/common.py's), analysed as the Blender
operator does by default (neutral, 30 fps, gestures on, seed 0), and
EmoDB's acted German sentences pooled per emotion preset.  Per clip:

* **blinks**: a minute; each one's time above half closed on the line's
  frames (min-max, ms); the share starting within 0.35 s of a pause, a
  pause being a gap of 0.25 s or more between the aligned words (@pause),
  or a stretch of 0.25 s or more with the voice 20 dB or more under its
  loud level, from the audio alone (@quiet);
* **gaze**: the longest stretch without a shift (s), the largest angle from
  rest (degrees);
* **head**: the spread (standard deviation) of its angle from rest while
  speaking (degrees), its mean angular speed in speech against pauses of
  0.5 s or more, and the correlation of its angular speed with loudness
  (dB) frame by frame.

The numbers of the gesture layer come from the literature (the presets);
only the clips marked ``seen`` were looked at while making it, the others
are held out.  Also printed: the time the layer adds to ``analyze`` (the
gesture layer alone, per second of audio).

    .venv/bin/python bench/gestures.py
    .venv/bin/python bench/gestures.py --long-only     # clips of 20 s or more
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from common import need_data, transcript_clips
from addon.engine import audio as audio_mod
from addon.engine import gestures, presets, prosody
from addon.engine.errors import LipSyncError
from addon.engine.pipeline import analyze
from addon.engine.settings import LineSettings

SEEN = {"acoustic_corpus", "cold_corpus", "p002"}
EMODB_PRESETS = {"W": "angry", "F": "happy", "A": "afraid", "N": "neutral", "T": "sad", "E": "disgusted",
                 "L": "neutral"}


def audio_pauses(tracks: prosody.Tracks, min_len: float = 0.25, below: float = 20.0) -> list[tuple[float, float]]:
    """Stretches of ``min_len`` s or more with the intensity ``below`` dB or
    more under its 95th percentile."""
    db = tracks.intensity
    quiet = db < np.percentile(db, 95) - below
    edges = np.flatnonzero(np.diff(np.r_[0, quiet.astype(int), 0]))
    step = tracks.times[1] - tracks.times[0]
    return [(tracks.times[a], tracks.times[b - 1] + step) for a, b in zip(edges[::2], edges[1::2])
            if (b - a) * step >= min_len]


def measure(result, tracks: prosody.Tracks) -> dict:
    m = result.gestures
    times, fps = m.times, result.fps
    minutes = result.duration / 60
    closed = np.concatenate([[False], m.blink > 0.5, [False]])
    edges = np.flatnonzero(np.diff(closed.astype(int)))
    lengths = (edges[1::2] - edges[::2]) / fps * 1000
    gaps = gestures.pauses(result.alignment)
    at_pause = [any(a - 0.35 <= s <= b + 0.35 for a, b in gaps) for s, _ in m.blinks]
    quiet = audio_pauses(tracks)
    at_quiet = [any(a - 0.35 <= s <= b + 0.35 for a, b in quiet) for s, _ in m.blinks]
    moving = np.flatnonzero(np.abs(np.diff(m.gaze, axis=0)).max(axis=1) > 0.05)
    shifts = times[moving[np.r_[True, np.diff(moving) > 2]]] if len(moving) else np.zeros(0)
    still = np.diff(np.r_[0.0, shifts, result.duration]).max()
    speaking = np.zeros(len(times), dtype=bool)
    for w in result.alignment.words:
        if w.spoken:
            speaking |= (times >= w.start) & (times < w.end)
    angle = np.linalg.norm(m.head, axis=1)
    speed = np.linalg.norm(np.diff(m.head, axis=0), axis=1) * fps
    pause = np.zeros(len(times), dtype=bool)
    for a, b in gaps:
        if b - a >= 0.5:   # pauses of 0.5 s or more between the words
            pause |= (times >= a) & (times < b)
    loud = np.interp(times[1:], tracks.times, tracks.intensity)
    ratio = speed[speaking[1:]].mean() / speed[pause[1:]].mean() if pause[1:].any() and speaking.any() else np.nan
    return {"blinks": len(m.blinks), "rate": len(m.blinks) / minutes,
            "len": (lengths.min(), lengths.max()) if len(lengths) else (np.nan, np.nan),
            "at_pause": float(np.mean(at_pause)) if at_pause else np.nan,
            "at_quiet": float(np.mean(at_quiet)) if at_quiet else np.nan, "still": still,
            "gaze_max": float(np.abs(m.gaze).max()), "spread": float(angle[speaking].std()) if speaking.any()
            else np.nan, "ratio": ratio, "r": float(np.corrcoef(speed, loud)[0, 1])}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--long-only", action="store_true", help="only clips of 20 s or more")
    args = ap.parse_args()
    data = need_data()
    settings = LineSettings.of("neutral", fps=30)
    print(f"{'clip':28s} {'s':>5s} {'blinks':>6s} {'/min':>5s} {'>half ms':>9s} {'@pause':>6s} {'@quiet':>6s} "
          f"{'still s':>7s} {'gaze°':>5s} {'head°':>5s} {'speech/pause':>12s} {'r loud':>6s}")
    rows, spent, audio_s = [], 0.0, 0.0
    for name, path, text in transcript_clips():
        snd = audio_mod.load(path)
        if args.long_only and snd.duration < 20:
            continue
        try:
            result = analyze(snd, text, settings)
        except LipSyncError as exc:
            print(f"{name:28s} refused: {exc}")
            continue
        tracks = prosody.analyse(snd)
        t0 = time.perf_counter()
        gestures.compute(result.alignment, result.times, tracks.times, tracks.pitch, tracks.intensity,
                         settings.emotion.gestures)
        spent += time.perf_counter() - t0
        audio_s += snd.duration
        row = measure(result, tracks)
        row["name"], row["seconds"], row["held"] = name, snd.duration, name not in SEEN
        rows.append(row)
        mark = "" if row["held"] else " (seen)"
        print(f"{name + mark:28s} {snd.duration:5.1f} {row['blinks']:6d} {row['rate']:5.1f} "
              f"{row['len'][0]:4.0f}-{row['len'][1]:<4.0f} {row['at_pause']:6.2f} {row['at_quiet']:6.2f} "
              f"{row['still']:7.1f} "
              f"{row['gaze_max']:5.1f} {row['spread']:5.2f} {row['ratio']:12.2f} {row['r']:6.2f}")
    for label, pick in (("held out", lambda r: r["held"]), ("seen", lambda r: not r["held"])):
        long = [r for r in rows if pick(r) and r["seconds"] >= 20]
        if not long:
            continue
        minutes = sum(r["seconds"] for r in long) / 60
        print(f"\n{label}, clips of 20 s or more ({len(long)}, {minutes:.1f} min):")
        print(f"  blinks a minute {sum(r['blinks'] for r in long) / minutes:.1f} "
              f"(per clip {min(r['rate'] for r in long):.1f}-{max(r['rate'] for r in long):.1f}); "
              f"above half closed {min(r['len'][0] for r in long):.0f}-{max(r['len'][1] for r in long):.0f} ms; "
              f"at a pause {np.nanmean([r['at_pause'] for r in long]):.2f} "
              f"(lowest {np.nanmin([r['at_pause'] for r in long]):.2f}; from the audio alone "
              f"{np.nanmean([r['at_quiet'] for r in long]):.2f})")
        print(f"  gaze: longest without a shift {max(r['still'] for r in long):.1f} s, "
              f"largest angle {max(r['gaze_max'] for r in long):.1f} deg")
        print(f"  head: spread in speech {min(r['spread'] for r in long):.2f}-{max(r['spread'] for r in long):.2f}"
              f" deg, speech/pause speed {np.nanmin([r['ratio'] for r in long]):.2f}-"
              f"{np.nanmax([r['ratio'] for r in long]):.2f}, r with loudness "
              f"{min(r['r'] for r in long):.2f}-{max(r['r'] for r in long):.2f}")
    if audio_s:
        print(f"\ngesture layer alone: {1000 * spent / audio_s:.2f} ms per second of audio")
    emodb = sorted((data / "emodb").glob("*.wav"))
    if emodb and not args.long_only:
        print("\nEmoDB, per emotion preset (sentences pooled):")
        pooled: dict[str, list] = {}
        for wav in emodb:
            preset = EMODB_PRESETS.get(wav.stem[5], "neutral")
            text = wav.with_suffix(".txt").read_text(encoding="utf-8")
            try:
                r = analyze(wav, text, LineSettings.of(preset, language="de"))
            except LipSyncError:
                continue
            pooled.setdefault(preset, []).append(r)
        for preset, results in sorted(pooled.items()):
            minutes = sum(r.duration for r in results) / 60
            blinks = [d for r in results for _, d in r.gestures.blinks]
            head = np.concatenate([np.linalg.norm(r.gestures.head, axis=1) for r in results])
            gaze = np.concatenate([r.gestures.gaze[:, 1] for r in results])
            print(f"  {preset:10s} {len(results):3d} takes {minutes:4.1f} min: {len(blinks) / minutes:5.1f} blinks "
                  f"a minute, {1000 * np.mean(blinks) if blinks else 0:4.0f} ms long; head {head.mean():.2f} deg "
                  f"from rest; gaze {gaze.mean():+.1f} deg up (preset: {presets.load(preset).gestures.gaze_down:+.1f}"
                  " down)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
