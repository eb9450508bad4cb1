"""Batch lip sync on a Dask cluster run the way a studio runs one: the
scheduler and the workers are separate ``dask`` processes started from a
folder outside the repository, with this environment's executables and no
path setting, so neither can import the engine unless the batch ships it."""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from addon.engine import batch
from addon.engine.pipeline import analyze

ROOT = Path(__file__).resolve().parent.parent
FIX = ROOT / "tests" / "fixtures"
HELLO = ROOT / "sample_rigs" / "speech" / "hello.wav"
BIN = Path(sys.executable).parent          # the environment's executables: python, dask
CLIPS = [("bob_map.wav", "bob_map.txt"), ("fast_bilabials.wav", "fast_bilabials.txt"), ("hello.wav", "hello.txt")]

# A worker environment without pocketsphinx, and one with another version of it.
NO_POCKETSPHINX = '''
import sys

class NoPocketsphinx:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] == "pocketsphinx":
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)

sys.meta_path.insert(0, NoPocketsphinx())
'''
OTHER_POCKETSPHINX = '''
import importlib.metadata

if not hasattr(importlib.metadata, "real_version"):
    importlib.metadata.real_version = importlib.metadata.version
    importlib.metadata.version = (lambda name: "5.0.0" if name == "pocketsphinx"
                                  else importlib.metadata.real_version(name))
'''


# A scheduler environment with another cloudpickle, as Dask reports it.
OTHER_CLOUDPICKLE = '''
import distributed.versions

if not hasattr(distributed.versions, "real_version"):
    distributed.versions.real_version = distributed.versions.version
    distributed.versions.version = (lambda name: "3.0.0" if name == "cloudpickle"
                                    else distributed.versions.real_version(name))
    distributed.versions._version_cached.cache_clear()
'''


class Cluster:
    """``dask scheduler`` and ``dask worker`` processes on 127.0.0.1, started
    in ``folder`` without PYTHONPATH; :meth:`stop` ends them and their children."""

    def __init__(self, folder: Path):
        self.folder = folder
        self.folder.mkdir(parents=True, exist_ok=True)
        self.procs: dict[str, subprocess.Popen] = {}
        self.env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        self.address = None

    def _start(self, name: str, *args: str) -> subprocess.Popen:
        log = open(self.folder / f"{name}.log", "wb")
        p = subprocess.Popen([str(BIN / "dask"), *args], cwd=self.folder, env=self.env, stdout=log,
                             stderr=subprocess.STDOUT, start_new_session=True)
        log.close()
        self.procs[name] = p
        return p

    def scheduler(self, *args: str) -> str:
        info = self.folder / "scheduler.json"
        self._start("scheduler", "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                    "--scheduler-file", str(info), *args)
        t0 = time.monotonic()
        while self.address is None:
            assert time.monotonic() - t0 < 30, "the scheduler did not start:\n" + self.logs()
            try:
                self.address = json.loads(info.read_text())["address"]
            except (OSError, ValueError, KeyError):
                time.sleep(0.1)
        return self.address

    def worker(self, name: str, *args: str) -> subprocess.Popen:
        return self._start(name, "worker", self.address, "--nthreads", "1", "--host", "127.0.0.1",
                           "--no-dashboard", "--local-directory", str(self.folder / name), *args)

    def wait_for_workers(self, n: int) -> None:
        import distributed

        with distributed.Client(self.address, timeout=30, set_as_default=False) as client:
            try:
                client.wait_for_workers(n, timeout=45)
            except TimeoutError:
                pytest.fail(f"{n} workers did not join:\n" + self.logs())

    def logs(self) -> str:
        return "\n".join(f"--- {p.name}\n" + p.read_text(errors="replace")[-3000:]
                         for p in sorted(self.folder.glob("*.log")))

    def stop(self) -> None:
        for p in self.procs.values():
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGTERM)
        for p in self.procs.values():
            try:
                p.wait(10)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait(10)
        for p in self.procs.values():   # a worker process the nanny left behind
            try:
                os.killpg(p.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass


@pytest.fixture
def cluster(tmp_path):
    c = Cluster(tmp_path / "cluster")
    try:
        yield c
    finally:
        c.stop()


@pytest.fixture
def lines(tmp_path):
    """A folder of recorded lines with their transcripts, outside the repository."""
    d = tmp_path / "lines"
    d.mkdir()
    for wav, txt in CLIPS:
        src = HELLO.parent if wav == "hello.wav" else FIX
        shutil.copy(src / wav, d / wav)
        shutil.copy(src / txt, d / txt)
    return d


def _manifest(folder: Path, n: int) -> list[dict]:
    rows = [{"audio": a, "transcript": t, "output": f"res/l{k:02d}"} for k in range(n) for a, t in [CLIPS[k % 3]]]
    (folder / "m.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    return rows


def _check_outputs(folder: Path, rows: list[dict], formats=("json",)) -> None:
    """Every line's outputs are byte for byte what ``analyze`` writes here."""
    refs = {}
    for wav, txt in CLIPS:
        res = analyze(folder / wav, (folder / txt).read_text())
        refs[wav] = {}
        for fmt in formats:
            path = folder / f"ref.{fmt}"
            (res.write_json if fmt == "json" else res.write_csv)(path)
            refs[wav][fmt] = path.read_bytes()
    for k, row in enumerate(rows):
        for fmt in formats:
            got = (folder / "res" / f"l{k:02d}.{fmt}").read_bytes()
            if fmt == "json":   # with the record of what made it first, made on the worker
                doc = json.loads(got)
                assert doc.pop("produced_by")["row"]["audio"] == row["audio"]
                got = json.dumps(doc, separators=(",", ":")).encode("utf-8")
            assert got == refs[row["audio"]][fmt], f"line {k + 1} ({row['audio']}) {fmt} differs from analyze's"


def _batch_cli(*args, timeout=120):
    t0 = time.monotonic()
    r = subprocess.run([sys.executable, "-m", "addon", "batch", *map(str, args)], cwd=ROOT, capture_output=True,
                       text=True, timeout=timeout)
    return r, time.monotonic() - t0


def test_the_environment_alone_cannot_import_the_engine(cluster):
    """What the other tests rely on: a process started like the cluster's does not find the engine."""
    r = subprocess.run([str(BIN / "python"), "-c", "import addon"], cwd=cluster.folder, env=cluster.env,
                       capture_output=True, text=True)
    assert r.returncode != 0 and "No module named 'addon'" in r.stderr


def test_separate_scheduler_and_workers_run_every_line_as_analyze_does(cluster, lines, tmp_path):
    address = cluster.scheduler()
    cluster.worker("workers", "--nworkers", "2")          # as docs/cluster.md starts them
    rows = _manifest(lines, 9)
    r, seconds = _batch_cli(lines / "m.jsonl", "--scheduler", address, "--json", "--csv",
                            "--report", tmp_path / "report.json")
    assert r.returncode == 0, r.stderr + cluster.logs()
    assert r.stderr == "" and r.stdout.startswith("9 lines: 9 done, 0 up to date, 0 failed"), r.stdout + r.stderr
    _check_outputs(lines, rows, ("json", "csv"))
    report = json.loads((tmp_path / "report.json").read_text())
    assert [ln["status"] for ln in report["lines"]] == ["ok"] * 9
    # both worker processes loaded the shipped engine, each in its own scratch folder
    unpacked = sorted(p.parent.parent.parent.parent.name for p in (cluster.folder / "workers").glob(
        "dask-scratch-space/worker-*/emotive-lipsync/emotive_lipsync_engine_*/batch/cluster.py"))
    assert len(unpacked) == 2, unpacked
    # The record the workers made is what a rerun compares: nothing to redo, here or on the cluster.
    r, _ = _batch_cli(lines / "m.jsonl", "--scheduler", address, "--json", "--csv")
    assert r.returncode == 0 and r.stdout.startswith("9 lines: 0 done, 9 up to date"), r.stdout + r.stderr
    r, _ = _batch_cli(lines / "m.jsonl", "--json", "--csv", "--emotion", "sad")
    assert r.returncode == 0 and r.stdout.startswith("9 lines: 9 done, 0 up to date"), r.stdout + r.stderr


@pytest.mark.parametrize("preload, says", [
    (NO_POCKETSPHINX, "cannot load the lip-sync engine: No module named 'pocketsphinx'"),
    (OTHER_POCKETSPHINX, "has pocketsphinx 5.0.0 where this machine has pocketsphinx 5.1.1"),
], ids=["missing-package", "other-version"])
def test_a_worker_that_cannot_load_the_engine_stops_the_batch_in_one_line(cluster, lines, preload, says):
    address = cluster.scheduler()
    (cluster.folder / "broken_env.py").write_text(preload)
    cluster.worker("broken", "--preload", str(cluster.folder / "broken_env.py"))
    _manifest(lines, 3)
    r, seconds = _batch_cli(lines / "m.jsonl", "--scheduler", address)
    assert r.returncode == 1, r.stdout + r.stderr
    assert seconds < 60
    assert r.stdout == ""
    assert len(r.stderr.splitlines()) == 1, r.stderr
    assert re.fullmatch(r"error: the Dask worker tcp://127\.0\.0\.1:\d+ " + re.escape(says) + r".*\n", r.stderr), \
        r.stderr
    assert not (lines / "res").exists()                  # nothing written


def test_a_scheduler_with_other_versions_stops_the_batch_in_one_line(cluster, lines):
    (cluster.folder / "other_env.py").write_text(OTHER_CLOUDPICKLE)
    address = cluster.scheduler("--preload", str(cluster.folder / "other_env.py"))
    _manifest(lines, 2)
    r, seconds = _batch_cli(lines / "m.jsonl", "--scheduler", address)
    assert r.returncode == 1
    assert r.stderr == (f"error: the Dask scheduler at {address} has cloudpickle 3.0.0 where this machine has "
                        "cloudpickle 3.1.3; the cluster needs this machine's Python and package versions "
                        "(see docs/cluster.md)\n")
    assert seconds < 60
    assert not (lines / "res").exists()


def test_no_worker_stops_the_batch_in_one_line_after_the_cluster_timeout(cluster, lines):
    address = cluster.scheduler()
    _manifest(lines, 2)
    r, seconds = _batch_cli(lines / "m.jsonl", "--scheduler", address, "--cluster-timeout", "3")
    assert r.returncode == 1
    assert r.stderr == f"error: no Dask worker joined the scheduler at {address} within 3 s\n"
    assert 3 <= seconds < 30
    assert not (lines / "res").exists()


def test_losing_every_worker_mid_run_stops_the_batch_in_one_line(cluster, lines):
    address = cluster.scheduler()
    worker = cluster.worker("w1", "--no-nanny")              # nothing restarts it
    cluster.wait_for_workers(1)
    _manifest(lines, 40)
    batch_run = subprocess.Popen([sys.executable, "-m", "addon", "batch", lines / "m.jsonl", "--scheduler", address,
                                  "--cluster-timeout", "4"], cwd=ROOT, stdout=subprocess.PIPE,
                                 stderr=subprocess.PIPE, text=True)
    try:
        t0 = time.monotonic()
        while not (lines / "res").is_dir() or not any((lines / "res").iterdir()):
            assert batch_run.poll() is None and time.monotonic() - t0 < 60, cluster.logs()
            time.sleep(0.05)
        os.killpg(worker.pid, signal.SIGKILL)
        t0 = time.monotonic()
        out, err = batch_run.communicate(timeout=60)
        seconds = time.monotonic() - t0
    finally:
        if batch_run.poll() is None:
            batch_run.kill()
    assert batch_run.returncode == 1
    assert re.fullmatch(rf"error: the Dask scheduler at {address} has had no workers for 4 s; \d+ lines not done "
                        r"\(the finished ones are kept; run again to do the rest\)\n", err), err
    assert 4 <= seconds < 20
    done = sorted(p.name for p in (lines / "res").iterdir())
    left = int(re.search(r"(\d+) lines not done", err).group(1))
    assert len(done) + left == 40 and all(p.endswith(".json") for p in done)   # no part-written file
    for name in done:
        json.loads((lines / "res" / name).read_text())


def test_a_worker_that_joins_later_and_cannot_load_the_engine_stops_the_batch_in_one_line(cluster, lines):
    address = cluster.scheduler()
    cluster.worker("good")
    cluster.wait_for_workers(1)
    (cluster.folder / "broken_env.py").write_text(NO_POCKETSPHINX)
    _manifest(lines, 90)
    batch_run = subprocess.Popen([sys.executable, "-m", "addon", "batch", lines / "m.jsonl", "--scheduler", address],
                                 cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        t0 = time.monotonic()
        while not (lines / "res").is_dir():
            assert batch_run.poll() is None and time.monotonic() - t0 < 60, cluster.logs()
            time.sleep(0.05)
        cluster.worker("broken", "--preload", str(cluster.folder / "broken_env.py"))
        out, err = batch_run.communicate(timeout=60)
    finally:
        if batch_run.poll() is None:
            batch_run.kill()
    assert batch_run.returncode == 1, out + err
    assert re.fullmatch(r"error: the Dask worker tcp://127\.0\.0\.1:\d+ cannot load the lip-sync engine: "
                        r"No module named 'pocketsphinx'; (\d+) lines not done \(the finished ones are kept; "
                        r"run again to do the rest\)\n", err), err
    left = int(re.search(r"(\d+) lines not done", err).group(1))
    assert len(list((lines / "res").iterdir())) == 90 - left


def test_unreachable_scheduler_stops_the_batch_in_one_line(lines):
    _manifest(lines, 2)
    r, seconds = _batch_cli(lines / "m.jsonl", "--scheduler", "tcp://127.0.0.1:9", "--cluster-timeout", "2")
    assert r.returncode == 1
    assert len(r.stderr.splitlines()) == 1
    assert r.stderr.startswith("error: cannot reach the Dask scheduler at tcp://127.0.0.1:9: ")
    assert seconds < 30


def test_cluster_timeout_must_be_positive(lines):
    _manifest(lines, 1)
    r, _ = _batch_cli(lines / "m.jsonl", "--scheduler", "tcp://127.0.0.1:9", "--cluster-timeout", "0")
    assert r.returncode == 1
    assert r.stderr == "error: --cluster-timeout must be more than 0 seconds, not 0\n"


def test_a_worker_killed_mid_run_loses_no_line(cluster, lines):
    import distributed

    address = cluster.scheduler()
    cluster.worker("w1")
    cluster.worker("w2")
    cluster.wait_for_workers(2)
    rows = _manifest(lines, 12)
    with distributed.Client(address, timeout=30, set_as_default=False) as watcher:
        pids = watcher.run(os.getpid)
        killed = []

        def kill_a_busy_worker(outcome):
            busy = [w for w, keys in watcher.processing().items() if keys]
            if not killed and busy:
                os.kill(pids[busy[0]], signal.SIGKILL)     # as a crash in a native library would
                killed.append(busy[0])

        rep = _within(90, lambda: batch.run(lines / "m.jsonl", scheduler=address, progress=False,
                                            on_outcome=kill_a_busy_worker))
        assert killed, "no worker was busy to kill"
        deadline = time.monotonic() + 10
        while killed[0] in watcher.scheduler_info(n_workers=-1)["workers"] and time.monotonic() < deadline:
            time.sleep(0.1)
        assert killed[0] not in watcher.scheduler_info(n_workers=-1)["workers"]
    assert rep.ok, rep.failure_lines()
    assert sorted(o.number for o in rep.outcomes) == list(range(1, 13))
    _check_outputs(lines, rows)


def _within(seconds, fn):
    """Run ``fn`` in a thread; fail the test (rather than hang CI) after ``seconds``."""
    import concurrent.futures

    ex = concurrent.futures.ThreadPoolExecutor(1)
    try:
        return ex.submit(fn).result(timeout=seconds)
    finally:
        ex.shutdown(wait=False)


def test_the_guide_installs_the_versions_this_environment_pins():
    """The guide's command for cluster machines (docs/cluster.md) pins what requirements.txt pins."""
    command = (ROOT / "docs" / "cluster.md").read_text().replace("\\\n", " ")
    pip = next(ln for ln in command.splitlines() if "pip install" in ln)
    wanted = dict(re.findall(r"([\w.-]+)==([\w.]+)", pip))
    pinned = dict(re.findall(r"^([\w.-]+)==([\w.]+)", (ROOT / "requirements.txt").read_text(), re.M))
    assert set(wanted) == {"numpy", "praat-parselmouth", "pocketsphinx", "dask", "distributed",
                            "cloudpickle", "soundfile", "av", "espeakng-loader", "pykakasi"}
    assert wanted == {k: pinned[k] for k in wanted}
