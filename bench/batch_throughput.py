"""Batch throughput on thousands of real short lines (../shared/data; skips
when absent).

Builds a manifest of short lines (0.6-4 s, the length of game dialogue) by
cutting the shared recordings at word boundaries, each cut with the words of
its reference transcript: the MFA clips at their reference word tiers, the
praatIO sentences at theirs, and the LibriVox sonnets, the LibriSpeech
utterance and the voice-quality clips at the word times of their whole
reference transcript aligned once here.  Then it runs ``batch.run`` on a
pool of one worker per core and reports

* lines per second and the projected time for 16,000 lines (target on 2
  cores: >= 10 lines/s, i.e. 16,000 lines in under 30 minutes);
* the worker processes' CPU time per line, which does not depend on what
  else runs on the machine, and the rate it allows on idle cores;
* the peak memory of each worker process (its VmHWM; target <= 300 MB);
* that every line was written and how many words came out estimated.

With ``--cluster`` it then runs the same lines on a Dask cluster of separate
processes on this machine, started as docs/cluster.md says (``dask scheduler``
and ``dask worker --nworkers N --nthreads 1`` from a folder outside the
repository, without PYTHONPATH), twice: first with workers that have not
seen the engine (it is shipped and loaded), then again; it reports lines per
second beside the local pool's, this process's CPU time per line, and
whether every output equals the local pool's byte for byte (a JSON output's record without the
time it was written).

    .venv/bin/python bench/batch_throughput.py [--lines N] [--workers N] [--keep DIR] [--cluster]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from common import DATA, need_data, write_wav
from addon.engine import audio as audio_mod
from addon.engine import batch
from addon.engine.importers import read_alignment
from addon.engine.alignment import align_file

MIN_LEN, MAX_LEN, MARGIN = 0.6, 4.0, 0.06


def word_times() -> list[tuple[str, audio_mod.Audio, list[tuple[str, float, float]]]]:
    """(name, audio, [(word, start, end)]) for every recording used."""
    out = []
    for name in ("acoustic_corpus", "cold_corpus"):
        al = read_alignment(DATA / "mfa" / f"{name}.TextGrid")
        out.append((name, audio_mod.load(DATA / "mfa" / f"{name}.wav"), [(w.text, w.start, w.end) for w in al.words]))
    for name in ("mary", "damon_set_test"):
        al = read_alignment(DATA / "praatio" / f"{name}.TextGrid")
        words = [(w.text, w.start, w.end) for w in al.words]
        out.append((name, audio_mod.load(DATA / "praatio" / f"{name}.wav"), words))
    aligned = [(p.stem, p, p.with_suffix(".txt").read_text(encoding="utf-8"))
               for p in sorted((DATA / "librivox").glob("*.mp3"))]
    aligned.append(("61-70968-0000", DATA / "mfa" / "61-70968-0000.flac",
                    (DATA / "mfa" / "61-70968-0000.lab").read_text(encoding="utf-8")))
    for row in (DATA / "voice_quality" / "transcripts.tsv").read_text(encoding="utf-8").splitlines()[1:]:
        fname, text, _ = row.split("\t")
        aligned.append((Path(fname).stem, DATA / "voice_quality" / fname, text))
    for name, path, text in aligned:
        snd = audio_mod.load(path)
        al = align_file(path, text)
        out.append((name, snd, [(w.text, w.start, w.end) for w in al.words if not w.estimated]))
    return out


def spans(words: list[tuple[str, float, float]]):
    """Every run of consecutive words lasting MIN_LEN-MAX_LEN s."""
    for i in range(len(words)):
        for j in range(i, len(words)):
            d = words[j][2] - words[i][1]
            if d > MAX_LEN:
                break
            if d >= MIN_LEN:
                yield i, j


def build(folder: Path, n_lines: int) -> Path:
    """Cut the recordings into at most ``n_lines`` lines (spread evenly over
    all the spans found); write the WAVs, transcripts and a CSV manifest."""
    cuts = []
    for name, snd, words in word_times():
        for i, j in spans(words):
            cuts.append((name, snd, words, i, j))
    if len(cuts) > n_lines:
        keep = np.linspace(0, len(cuts) - 1, n_lines).round().astype(int)
        cuts = [cuts[k] for k in sorted(set(keep))]
    rows = ["audio,transcript"]
    for k, (name, snd, words, i, j) in enumerate(cuts):
        lo = max(0.0, words[i][1] - MARGIN, words[i - 1][2] if i else 0.0)
        hi = min(snd.duration, words[j][2] + MARGIN, words[j + 1][1] if j + 1 < len(words) else snd.duration)
        samples = snd.samples[int(lo * snd.rate):int(hi * snd.rate)]
        if snd.rate != 16000:
            t = np.arange(int(len(samples) * 16000 / snd.rate)) / 16000
            samples = np.interp(t, np.arange(len(samples)) / snd.rate, samples)
        stem = f"{k:05d}_{name}"
        write_wav(folder / f"{stem}.wav", samples)
        (folder / f"{stem}.txt").write_text(" ".join(w for w, _, _ in words[i:j + 1]) + "\n", encoding="utf-8")
        rows.append(f"{stem}.wav,{stem}.txt")
    manifest = folder / "lines.csv"
    manifest.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return manifest


class WorkerMemory:
    """Polls the high-water mark (VmHWM) of every process below this one."""

    def __init__(self):
        self.peak: dict[int, int] = {}
        self.cpu: dict[int, float] = {}     # user + system seconds of each process
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def __enter__(self):
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()

    def _poll(self):
        import psutil

        for child in psutil.Process().children(recursive=True):
            try:
                with open(f"/proc/{child.pid}/status") as fh:
                    hwm = next(int(ln.split()[1]) for ln in fh if ln.startswith("VmHWM"))
                self.peak[child.pid] = max(self.peak.get(child.pid, 0), hwm)
                t = child.cpu_times()
                self.cpu[child.pid] = t.user + t.system
            except (OSError, StopIteration, psutil.Error):
                pass

    def _run(self):
        while not self._stop.wait(0.25):
            self._poll()


@contextmanager
def dask_cluster(workers: int):
    """A scheduler and ``workers`` worker processes on 127.0.0.1, started
    from a temporary folder without PYTHONPATH; yields the address."""
    import distributed

    folder = Path(tempfile.mkdtemp(prefix="lipsync_cluster_"))
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    dask = str(Path(sys.executable).parent / "dask")
    procs = []

    def start(*args):
        with open(folder / f"{len(procs)}.log", "wb") as log:
            procs.append(subprocess.Popen([dask, *args], cwd=folder, env=env, stdout=log, stderr=subprocess.STDOUT,
                                          start_new_session=True))

    try:
        start("scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
              "--scheduler-file", str(folder / "scheduler.json"))
        t0 = time.monotonic()
        while not (folder / "scheduler.json").exists():
            if time.monotonic() - t0 > 60:
                raise SystemExit("the scheduler did not start")
            time.sleep(0.1)
        time.sleep(0.2)
        address = json.loads((folder / "scheduler.json").read_text())["address"]
        start("worker", address, "--nworkers", str(workers), "--nthreads", "1", "--host", "127.0.0.1",
              "--no-dashboard", "--local-directory", str(folder / "workers"))
        with distributed.Client(address, timeout=60, set_as_default=False) as client:
            client.wait_for_workers(workers, timeout=120)
        yield address
    finally:
        for p in procs:
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGTERM)
        for p in procs:
            try:
                p.wait(15)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait()
        shutil.rmtree(folder, ignore_errors=True)


def digests(report: batch.Report) -> dict[str, str]:
    """Each output's hash, a JSON output's without the time its record was written (``recorded_ns``,
    which differs from run to run)."""
    def content(path: str) -> bytes:
        if path.endswith(".json"):
            doc = json.loads(Path(path).read_text(encoding="utf-8"))
            doc.get("produced_by", {}).pop("recorded_ns", None)
            return json.dumps(doc, sort_keys=True).encode()
        return Path(path).read_bytes()

    return {o: hashlib.sha256(content(o)).hexdigest() for out in report.outcomes for o in out.outputs}


def tree_cpu() -> float:
    """User + system CPU seconds of this process and every process below it."""
    import psutil

    total = 0.0
    for proc in [psutil.Process(), *psutil.Process().children(recursive=True)]:
        try:
            t = proc.cpu_times()
            total += t.user + t.system
        except psutil.Error:
            pass
    return total


def cluster_runs(manifest: Path, workers: int, local_rate: float, local_cpu: float, local: dict[str, str]) -> None:
    print(f"Dask cluster on this machine: a scheduler and {workers} worker processes (separate, no PYTHONPATH)")
    with dask_cluster(workers) as address:
        for run in ("engine shipped and loaded", "engine already loaded"):
            cpu0, own0 = tree_cpu(), time.process_time()
            report = batch.run(manifest, scheduler=address, force=True, progress=None)
            done = max(report.count("ok"), 1)
            cpu, own = (tree_cpu() - cpu0) / done, (time.process_time() - own0) / done
            rate = report.count("ok") / report.seconds
            same = sum(local.get(o) == h for o, h in digests(report).items())
            print(f"  {run}: {report.summary()}")
            print(f"    throughput {rate:.1f} lines/s, the local pool {local_rate:.1f} "
                  f"({100 * rate / local_rate:.0f} %); {same} of {len(local)} outputs byte-identical to its")
            print(f"    CPU per line, every process {1000 * cpu:.0f} ms (the local pool {1000 * local_cpu:.0f} ms): "
                  f"{os.cpu_count() / cpu:.1f} lines/s on {os.cpu_count()} otherwise idle cores "
                  f"(the local pool {os.cpu_count() / local_cpu:.1f}); this process {1000 * own:.1f} ms")
            for msg in report.failure_lines()[:10]:
                print("    failed:", msg)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--lines", type=int, default=2400)
    ap.add_argument("--workers", type=int, default=0)
    ap.add_argument("--keep", metavar="DIR", help="build the lines here and keep them")
    ap.add_argument("--cluster", action="store_true",
                    help="then run the lines on a Dask cluster of separate processes here, beside the local pool")
    args = ap.parse_args()
    need_data()
    folder = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="lipsync_batch_"))
    folder.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    manifest = build(folder, args.lines)
    wavs = sorted(folder.glob("*.wav"))
    total_audio = sum(audio_mod.load(p).duration for p in wavs[::50]) * 50
    print(f"built {len(wavs)} lines (about {total_audio / 60:.0f} min of speech, "
          f"{MIN_LEN}-{MAX_LEN} s each) in {time.perf_counter() - t0:.0f} s")

    workers = args.workers or os.cpu_count() or 1
    own0 = time.process_time()
    with WorkerMemory() as mem:
        report = batch.run(manifest, workers=workers, force=True, progress=None)
    own = time.process_time() - own0
    rate = report.count("ok") / report.seconds
    print(f"{workers} workers ({os.cpu_count()} cores): {report.summary()}")
    print(f"  throughput {rate:.1f} lines/s  (target >= 10)")
    print(f"  16,000 lines projected: {16000 / rate / 60:.1f} min  (target < 30 min)")
    cpu = sum(mem.cpu.values()) / max(report.count("ok"), 1)
    print(f"  worker CPU per line {1000 * cpu:.0f} ms: {os.cpu_count() / cpu:.1f} lines/s on {os.cpu_count()} "
          "otherwise idle cores (the rate above is lower when other programs share the cores)")
    peaks = sorted(mem.peak.values(), reverse=True)
    print("  peak memory per worker process: " + ", ".join(f"{p / 1024:.0f} MB" for p in peaks[:workers + 1])
          + "  (target <= 300 MB)")
    outs = [json.loads(Path(o).read_text()) for out in report.outcomes for o in out.outputs[:1]]
    words = sum(len(o["words"]) for o in outs)
    est = sum(w["estimated"] for o in outs for w in o["words"])
    print(f"  {len(outs)} outputs, {words} words, {est} estimated ({100 * est / max(words, 1):.1f} %)")
    for msg in report.failure_lines()[:10]:
        print("  failed:", msg)
    if args.cluster:
        cluster_runs(manifest, workers, rate, cpu + own / max(report.count("ok"), 1), digests(report))
    if not args.keep:
        shutil.rmtree(folder)


if __name__ == "__main__":
    main()
