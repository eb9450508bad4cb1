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
  (target: under 400 MB);
* with ``--against CHECKOUT`` (another version of the project, e.g. the one
  before the checks of a take against its script: ``git worktree add
  /tmp/before 48cc5ce``), whole ``analyze`` in-process on every English
  clip with a transcript (bench/common.py ``transcript_clips``, and
  TIMIT's 61 sentences), each version in a process of its own with its
  models loaded (as a batch worker or a Blender session has them), the two
  taking turns clip by clip, best of 3: each clip's time per second of
  audio in both and their ratio (targets: at most 0.05 and 1.15).

    .venv/bin/python bench/speed.py
    .venv/bin/python bench/speed.py --against /tmp/before --only-against
    .venv/bin/python bench/speed.py --against /tmp/prev --only-against --clips mfa_ corpus
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

#: A process timing ``analyze`` for the checkout whose folder is its first argument: it reads
#: "path\ttranscript file" lines and answers each with the best of 3 wall times.
_TIMER = """
import sys, time
sys.path.insert(0, sys.argv[1])
from addon.engine import audio as audio_mod
from addon.engine.pipeline import analyze
ready = False
for line in sys.stdin:
    path, text_path = line.rstrip("\\n").split("\\t")
    snd, text = audio_mod.load(path), open(text_path, encoding="utf-8").read()
    if not ready:
        analyze(snd, text)
        ready = True
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        analyze(snd, text)
        times.append(time.perf_counter() - t0)
    print(min(times), snd.duration, flush=True)
"""


def against(other: str, only: list[str] | None = None) -> None:
    """Every English clip with a transcript (``only``: those whose name holds one of these), analysed
    in-process by this checkout and by ``other``, taking turns clip by clip."""
    import os
    from pathlib import Path

    tmp = Path(tempfile.mkdtemp())
    clips = __import__("common").timed_clips()
    if only:
        clips = [c for c in clips if any(o in c[0] for o in only)]
    timers = {}
    for label, root in (("this", str(ROOT)), ("other", os.path.abspath(other))):
        timers[label] = subprocess.Popen([sys.executable, "-c", _TIMER, root],
                                         stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, cwd=root)
    print(f"whole analyze in-process, this checkout against {other} (best of 3, taking turns):")
    print(f"  {'clip':26s} {'audio s':>7s} {'this x rt':>9s} {'other':>7s} {'ratio':>6s}")
    rows = []
    for k, (name, path, text) in enumerate(clips):
        text_path = tmp / f"{k}.txt"
        text_path.write_text(text, encoding="utf-8")
        got = {}
        for label in ("this", "other"):
            timers[label].stdin.write(f"{path}\t{text_path}\n")
            timers[label].stdin.flush()
            seconds, duration = map(float, timers[label].stdout.readline().split())
            got[label] = seconds
        rows.append((name, duration, got["this"], got["other"]))
        print(f"  {name:26s} {duration:7.1f} {got['this'] / duration:9.3f} {got['other'] / duration:7.3f} "
              f"{got['this'] / got['other']:6.2f}", flush=True)
    for t in timers.values():
        t.stdin.close()
        t.wait()
    a = np.array([r[1:] for r in rows])
    seconds, this, that = a[:, 0], a[:, 1], a[:, 2]
    ratio, rt = this / that, this / seconds
    print(f"  all {len(rows)} clips: {this.sum() / seconds.sum():.3f} x rt against {that.sum() / seconds.sum():.3f} "
          f"(ratio {this.sum() / that.sum():.2f}); median ratio {np.median(ratio):.2f}, highest {ratio.max():.2f} "
          f"({rows[int(ratio.argmax())][0]}); highest x rt {rt.max():.3f} ({rows[int(rt.argmax())][0]})")


if __name__ == "__main__":
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--against", help="another checkout of the project, timed beside this one clip by clip")
    ap.add_argument("--only-against", action="store_true", help="only that comparison")
    ap.add_argument("--clips", nargs="*", help="with --against, only the clips whose name holds one of these")
    args = ap.parse_args()
    if not args.only_against:
        main()
    if args.against:
        need_data()
        against(args.against, args.clips)
