"""Speed and memory of ``analyze`` on real recordings (../shared/data; skips
when absent).

* ``python -m addon analyze`` as a whole, fresh process (start-up, imports,
  decode, align, prosody, curves, JSON written) on the two ~26 s MFA clips,
  best of 3 wall-clock times as a share of the audio's duration (target: at
  most 0.05), with the CPU time of the process and its workers over the
  wall time (about 2 when both cores are busy);
* whole ``analyze`` (decode, align, prosody, curves) in-process on the two
  ~52 s sonnets and on the two MFA clips joined, as a share of the audio's
  duration (target: at most 0.05);
* the curves step alone for 100 s of audio at 30 fps (target: under 50 ms);
* peak memory of a fresh ``python -m addon analyze`` on a ~100 s clip
  (target: under 400 MB).

    .venv/bin/python bench/speed.py
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time

import numpy as np

from common import DATA, ROOT, need_data, write_wav
from addon.engine import audio as audio_mod
from addon.engine import presets, visemes
from addon.engine.pipeline import analyze
from addon.engine.render import curves
from addon.engine.alignment import AlignedPhone, Alignment
from addon.engine.prosody import ClipStats



def timed_analyze(path, text, repeat=3):
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        r = analyze(path, text)
        best = min(best, time.perf_counter() - t0)
    return best, r


def whole_process(path, transcript, out, repeat=3) -> tuple[float, float]:
    """Best wall time of a fresh ``python -m addon analyze`` and the CPU
    time (its own and its workers') per second of wall time in that run."""
    import os
    import resource

    # Bytecode is cached as on any installed copy (Blender's extensions too).
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    best = (float("inf"), 0.0)
    for _ in range(repeat):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "addon", "analyze", str(path), "--transcript", str(transcript),
                        "--json", str(out), "--quiet"], cwd=ROOT, check=True, env=env)
        wall = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        best = min(best, (wall, cpu / wall))
    return best


def main():
    need_data()
    tmp = tempfile.mkdtemp()
    print("python -m addon analyze as a whole process (best of 3):")
    for name in ("acoustic_corpus", "cold_corpus"):
        wav = DATA / "mfa" / f"{name}.wav"
        wall, cores = whole_process(wav, wav.with_suffix(".lab"), f"{tmp}/{name}.json")
        duration = audio_mod.load(wav).duration
        print(f"  {name:16s} {duration:5.1f} s audio  {wall:5.2f} s  = {wall / duration:.3f} x duration"
              f"  (CPU/wall {cores:.2f})")
    print("whole analyze (best of 3), 2 cores:")
    cases = []
    for name in ("p002", "p003"):
        cases.append((name, DATA / "librivox" / f"{name}.mp3", (DATA / "librivox" / f"{name}.txt").read_text()))
    a = audio_mod.load(DATA / "mfa/acoustic_corpus.wav")
    b = audio_mod.load(DATA / "mfa/cold_corpus.wav")
    joined = f"{tmp}/mfa_joined.wav"
    write_wav(joined, np.concatenate([a.samples, b.samples]))
    cases.append(("mfa joined", joined, (DATA / "mfa/acoustic_corpus.lab").read_text() + "\n"
                  + (DATA / "mfa/cold_corpus.lab").read_text()))
    for name, path, text in cases:
        dt, r = timed_analyze(path, text)
        print(f"  {name:12s} {r.duration:6.1f} s audio  {dt:5.2f} s  = {dt / r.duration:.3f} x duration"
              f"  ({r.alignment.n_estimated} of {len(r.alignment.phones)} phonemes estimated)")

    # Curves alone: 100 s of synthetic phonemes at a speaking rate of 12 phones/s.
    rng = np.random.default_rng(0)
    phones = sorted({"AA", "IY", "UW", "M", "B", "P", "S", "T", "K", "L", "R", "F", "EH", "OW"})
    t, al = 0.0, []
    while t < 100:
        d = rng.uniform(0.05, 0.15)
        al.append(AlignedPhone(str(rng.choice(phones)), t, t + d, 0))
        t += d
    alignment = Alignment([], al, 100.0)
    n = len(al)
    stats = ClipStats(100, 150, 200, 40, 60, 80, True)
    vset, preset = visemes.load("default"), presets.load("neutral")
    for model in ("dominance", "rules"):
        best = float("inf")
        for _ in range(5):
            t0 = time.perf_counter()
            curves(alignment, np.full(n, 150.0), np.full(n, 60.0), stats, vset, preset, model, 30)
            best = min(best, time.perf_counter() - t0)
        print(f"curves alone, 100 s at 30 fps, {n} phonemes, {model:9s}: {best * 1000:6.1f} ms")

    long_wav = f"{tmp}/long.wav"
    s2 = audio_mod.load(DATA / "librivox/p002.mp3")
    s3 = audio_mod.load(DATA / "librivox/p003.mp3")
    write_wav(long_wav, np.concatenate([s2.samples, s3.samples]))
    text = (DATA / "librivox/p002.txt").read_text() + "\n" + (DATA / "librivox/p003.txt").read_text()
    txt = f"{tmp}/long.txt"
    open(txt, "w").write(text)
    # Measured inside a fresh process: the high-water mark of its own memory
    # (VmHWM: ru_maxrss would also count the pages this benchmark process
    # held when it forked the probe) and the largest alignment worker.
    probe = ("import resource, sys; from addon.engine.cli import main; code = main(['analyze'] + sys.argv[1:]); "
             "hwm = next(int(l.split()[1]) for l in open('/proc/self/status') if l.startswith('VmHWM')); "
             "print(max(hwm, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)); sys.exit(code)")
    out = subprocess.run([sys.executable, "-c", probe, long_wav, "--transcript", txt, "--json",
                          f"{tmp}/long.json", "--quiet"], cwd=ROOT, check=True, capture_output=True, text=True)
    peak = int(out.stdout.split()[-1])
    print(f"peak memory of analyze on {s2.duration + s3.duration:.0f} s: {peak / 1024:.0f} MB "
          "(largest single process: the main one or an alignment worker; target < 400 MB)")

if __name__ == "__main__":
    main()
