"""Time and peak memory of ``python -m addon analyze`` on long recordings.

The recordings are made by joining the project's own speech clips (the test
fixtures and the sample line, with their transcripts) with short pauses
until they last 1, 10 and 30 minutes; each is analysed by a fresh process
of the command line, whose wall time, CPU time and peak memory are reported: the resident
memory of its largest process, and that of the process with its aligner
workers together (sampled; proportional set sizes, so the memory the forked
workers share with it counts once).  Target: under 500 MB for any length,
and no more time per second of audio than on short clips.

    .venv/bin/python bench/long_audio.py               # 1, 10 and 30 minutes
    .venv/bin/python bench/long_audio.py --minutes 1 10
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
import wave

import numpy as np

from common import ROOT

CLIPS = [
    (ROOT / "tests" / "fixtures" / "bob_map.wav", "Bob bought a map."),
    (ROOT / "tests" / "fixtures" / "fast_bilabials.wav", "Maybe Bobby makes pumpkin pie, baby."),
    (ROOT / "tests" / "fixtures" / "pause.wav", "First part of the line. And the second part after a long pause."),
    (ROOT / "sample_rigs" / "speech" / "hello.wav", None),
]
RATE = 22050
GAP = 0.4  # s of silence between clips


def _read(path) -> np.ndarray:
    with wave.open(str(path)) as w:
        assert w.getframerate() == RATE and w.getsampwidth() == 2 and w.getnchannels() == 1, path
        return np.frombuffer(w.readframes(w.getnframes()), "<i2")


def make_recording(folder: str, minutes: float) -> tuple[str, str]:
    """A WAV file of ``minutes`` of speech and its transcript, in ``folder``."""
    clips = []
    for path, text in CLIPS:
        if text is None:
            text = path.with_suffix(".txt").read_text(encoding="utf-8").strip()
        clips.append((_read(path), text))
    gap = np.zeros(int(GAP * RATE), "<i2")
    wav = os.path.join(folder, f"long_{minutes:g}min.wav")
    words = []
    n, k, target = 0, 0, int(minutes * 60 * RATE)
    with wave.open(wav, "wb") as w:
        w.setnchannels(1), w.setsampwidth(2), w.setframerate(RATE)
        while n < target:
            samples, text = clips[k % len(clips)]
            w.writeframes(samples.tobytes() + gap.tobytes())
            words.append(text)
            n += len(samples) + len(gap)
            k += 1
    txt = wav[:-4] + ".txt"
    with open(txt, "w", encoding="utf-8") as fh:
        fh.write("\n".join(words) + "\n")
    return wav, txt


def _pss(pid: int) -> int:
    """Proportional set size (bytes): the process's resident memory, with
    pages it shares with other processes (forked workers) divided among them."""
    try:
        with open(f"/proc/{pid}/smaps_rollup") as fh:
            for line in fh:
                if line.startswith("Pss:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0


def _tree_rss(root: int) -> int:
    """Memory (bytes) of process ``root`` and all its descendants (the
    aligner's worker processes), from /proc: the sum of their proportional
    set sizes, so memory the forked workers share with their parent (the
    audio) counts once."""
    parent, rss = {}, {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as fh:
                fields = fh.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        parent[int(entry)] = int(fields[1])
        rss[int(entry)] = _pss(int(entry))
    total, todo = 0, [root]
    while todo:
        pid = todo.pop()
        total += rss.get(pid, 0)
        todo += [c for c, p in parent.items() if p == pid]
    return total


def measure(wav: str, txt: str, out: str) -> tuple[float, float, float, float, int, str]:
    """(wall seconds, CPU seconds of the process and its workers, peak RSS
    of the largest process in MB, peak memory of the whole process tree in
    MB (sampled every 0.2 s), exit status, last line) of one analyze run."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    t0 = time.perf_counter()
    with tempfile.TemporaryFile("w+") as log:
        proc = subprocess.Popen([sys.executable, "-m", "addon", "analyze", wav, "--transcript", txt,
                                 "--json", out], stdout=log, stderr=subprocess.STDOUT, env=env, cwd=ROOT)
        tree = 0
        while True:
            pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
            if pid:
                break
            tree = max(tree, _tree_rss(proc.pid))
            time.sleep(0.2)
        seconds = time.perf_counter() - t0
        log.seek(0)
        lines = [ln for ln in log.read().splitlines() if ln.strip()]
    proc.returncode = os.waitstatus_to_exitcode(status)
    cpu = usage.ru_utime + usage.ru_stime  # includes the workers it waited for
    return seconds, cpu, usage.ru_maxrss / 1024.0, tree / 2**20, proc.returncode, lines[-1] if lines else ""


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, nargs="+", default=[1, 10, 30])
    args = ap.parse_args()
    print(f"{'minutes':>7} {'wall s':>8} {'x real':>7} {'CPU s':>7} {'x real':>7} {'peak MB':>8} {'all MB':>7}"
          f"  status  last line")
    print("(x real: seconds per second of audio; CPU: the process and its workers together, unaffected by "
          "other programs sharing the cores;\n peak: the largest process's resident memory; all: the process "
          "and its workers together, shared pages counted once)")
    worst = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        for minutes in args.minutes:
            wav, txt = make_recording(tmp, minutes)
            seconds, cpu, peak, tree, status, last = measure(wav, txt, os.path.join(tmp, "out.json"))
            worst = max(worst, peak, tree)
            real = minutes * 60
            print(f"{minutes:7g} {seconds:8.1f} {seconds / real:7.3f} {cpu:7.1f} {cpu / real:7.3f} {peak:8.0f} "
                  f"{tree:7.0f}  {status:6d}  {last[:90]}", flush=True)
            os.remove(wav)
    print(f"peak memory target 500 MB: {'met' if worst < 500 else 'NOT met'} (worst {worst:.0f} MB)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
