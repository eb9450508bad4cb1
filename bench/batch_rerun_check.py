"""How long a batch rerun takes to find that its lines are up to date.

Each output records what made it (``produced_by``: the engine, the manifest
row, the options, the presets' and the line's files' contents).  A rerun
compares that record with the current one; the audio is read again only
when its size or time changed.  This builds N lines (each its own copy of a
recorded line, 48 kHz 16-bit, padded to ``--seconds`` s, and its transcript; every
output made by the engine once, then written for each line with its
record), and times ``batch.run`` over them:

* untouched: every line up to date (the cost a studio pays on each rerun);
* touched: every audio file touched, same content (after a checkout or a
  copy), so every file is read and hashed again, and found the same;
* edited: one line's transcript edited, that line alone redone.

    .venv/bin/python bench/batch_rerun_check.py [--lines N] [--seconds S] [--keep DIR]
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from addon.engine import batch
from addon.engine.pipeline import analyze
from addon.engine.settings import LineSettings

ROOT = Path(__file__).resolve().parent.parent
FIX = ROOT / "tests" / "fixtures"


def _speech() -> np.ndarray:
    """The fixture's recorded line (22.05 kHz) as 16-bit samples."""
    import wave

    with wave.open(str(FIX / "bob_map.wav")) as w:
        return np.frombuffer(w.readframes(w.getnframes()), "<i2")


def _wav(path: Path, speech: np.ndarray, seconds: float, seed: int) -> None:
    """A 48 kHz 16-bit mono WAV of ``seconds``: the speech, then quiet noise
    (its own for each line, so that no two files are alike)."""
    import wave

    n = int(seconds * 48000)
    x = np.interp(np.arange(n) * 22050 / 48000, np.arange(len(speech)), speech, right=0.0)
    x += np.random.default_rng(seed).normal(0, 20, n)
    with wave.open(str(path), "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(48000)
        w.writeframes(np.clip(x, -32768, 32767).astype("<i2").tobytes())


def _timed(manifest: Path) -> tuple[float, batch.Report]:
    t0 = time.perf_counter()
    rep = batch.run(manifest, workers=1, progress=False)
    return time.perf_counter() - t0, rep


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", type=int, default=2000)
    ap.add_argument("--seconds", type=float, default=3.0, help="length of each line's audio")
    ap.add_argument("--keep", metavar="DIR", help="build the lines in DIR and keep them")
    args = ap.parse_args()

    root = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="lipsync-rerun-"))
    root.mkdir(parents=True, exist_ok=True)
    try:
        result = analyze(FIX / "bob_map.wav", (FIX / "bob_map.txt").read_text())
        rows, speech = ["audio,transcript"], _speech()
        for k in range(args.lines):
            _wav(root / f"l{k:05d}.wav", speech, args.seconds, k)
            (root / f"l{k:05d}.txt").write_text("Bob bought a map.\n")
            rows.append(f"l{k:05d}.wav,l{k:05d}.txt")
        manifest = root / "lines.csv"
        manifest.write_text("\n".join(rows) + "\n")
        old = time.time_ns() - 3600 * 10**9     # recorded an hour ago, as a studio's files are
        for p in root.iterdir():
            os.utime(p, ns=(old, old))
        size = sum(p.stat().st_size for p in root.glob("*.wav"))
        digests = batch.Digests()
        t0 = time.perf_counter()
        for ln in batch.read_manifest(manifest):
            batch.write_outputs(ln, result, batch.produced_by(ln, LineSettings.of(), digests=digests))
        print(f"{args.lines} lines of {args.seconds:g} s ({size / 2**20:.0f} MiB of audio); records made and "
              f"outputs written in {time.perf_counter() - t0:.2f} s")

        dt, rep = _timed(manifest)
        assert rep.count("skipped") == args.lines, rep.summary()
        print(f"untouched: {dt:.2f} s, {args.lines / dt:,.0f} lines/s checked ({rep.summary()})")

        for p in root.glob("*.wav"):
            os.utime(p)
        dt, rep = _timed(manifest)
        assert rep.count("skipped") == args.lines, rep.summary()
        print(f"touched:   {dt:.2f} s, {args.lines / dt:,.0f} lines/s, {size / 2**20 / dt:,.0f} MiB/s hashed "
              f"({rep.summary()})")

        (root / "l00000.txt").write_text("Bob bought the map.\n")
        dt, rep = _timed(manifest)
        assert rep.count("ok") == 1 and rep.count("skipped") == args.lines - 1, rep.summary()
        print(f"edited:    {dt:.2f} s ({rep.summary()})")
    finally:
        if not args.keep:
            shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
