"""Batch lip sync: manifests, resumable outputs, failure reports, the
process pool and a Dask cluster (a LocalCluster on loopback)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from addon.engine import batch
from addon.engine.pipeline import analyze
from addon.engine.settings import LineSettings

ROOT = Path(__file__).resolve().parent.parent
FIX = ROOT / "tests" / "fixtures"
HELLO = ROOT / "sample_rigs" / "speech" / "hello.wav"


@pytest.fixture
def lines_dir(tmp_path):
    """A folder of real recorded lines with their transcripts beside them."""
    d = tmp_path / "lines"
    (d / "sub").mkdir(parents=True)
    for name in ("bob_map", "fast_bilabials"):
        shutil.copy(FIX / f"{name}.wav", d / f"{name}.wav")
        shutil.copy(FIX / f"{name}.txt", d / f"{name}.txt")
    shutil.copy(HELLO, d / "sub" / "hello.wav")
    shutil.copy(HELLO.with_suffix(".txt"), d / "sub" / "hello.txt")
    return d


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "addon", *map(str, args)], cwd=ROOT, capture_output=True,
                          text=True, timeout=300)


def _words(path):
    return [w["word"] for w in json.loads(Path(path).read_text())["words"]]


def test_manifest_csv_and_jsonl_resolve_paths_and_outputs(lines_dir, tmp_path):
    (lines_dir / "m.csv").write_text(
        "audio,transcript,text,emotion,viseme_set,fps,output\n"
        "bob_map.wav,bob_map.txt,,,,,\n"
        "sub/hello.wav,,hello there,happy,arkit,24,res/h\n"
        ",,no audio,,,,\n"
        "fast_bilabials.wav,fast_bilabials.txt,inline too,,,,\n")
    lines = batch.read_manifest(lines_dir / "m.csv", ("json", "csv"), out_dir=str(tmp_path / "o"))
    assert [ln.number for ln in lines] == [2, 3, 4, 5]
    a, b, c, d = lines
    assert a.audio == str(lines_dir / "bob_map.wav") and a.transcript == str(lines_dir / "bob_map.txt")
    assert a.outputs == {"json": str(tmp_path / "o" / "bob_map.json"), "csv": str(tmp_path / "o" / "bob_map.csv")}
    assert (b.text, b.emotion, b.viseme_set, b.fps) == ("hello there", "happy", "arkit", "24")
    assert b.outputs["json"] == str(lines_dir / "res" / "h.json")
    assert c.problem == "no audio file named"
    assert "not both" in d.problem

    (lines_dir / "m.jsonl").write_text(
        json.dumps({"audio": "sub/hello.wav", "transcript": "sub/hello.txt"}) + "\n\n"
        + "{broken\n" + json.dumps({"audio": "bob_map.wav", "text": "Bob bought a map."}) + "\n")
    j = batch.read_manifest(lines_dir / "m.jsonl")
    assert [ln.number for ln in j] == [1, 3, 4]
    assert j[0].outputs == {"json": str(lines_dir / "sub" / "hello.json")}   # beside the audio by default
    assert "not valid JSON" in j[1].problem
    assert j[2].text == "Bob bought a map." and j[2].problem is None


def test_two_lines_writing_one_file_are_refused(lines_dir):
    (lines_dir / "m.csv").write_text("audio,text\nbob_map.wav,Bob bought a map.\nbob_map.wav,Bob bought a map\n")
    a, b = batch.read_manifest(lines_dir / "m.csv")
    assert a.problem is None and "also written by line 2" in b.problem


def test_batch_writes_what_analyze_writes_and_reports_failures(lines_dir, tmp_path):
    (lines_dir / "m.csv").write_text(
        "audio,transcript,text,emotion\n"
        "bob_map.wav,bob_map.txt,,angry\n"
        "missing.wav,,hello,\n"
        "fast_bilabials.wav,,,\n"          # transcript found beside the audio
        "sub/hello.wav,,,no_such_emotion\n"
        "bob_map.wav,,,\n")                # same output as line 2: refused
    report_path = tmp_path / "report.json"
    r = _cli("batch", lines_dir / "m.csv", "--json", "--csv", "--workers", "2", "--report", report_path)
    assert r.returncode == 1
    assert "Traceback" not in r.stderr
    failed = [ln for ln in r.stderr.splitlines() if ln.startswith("failed:")]
    assert len(failed) == 3
    assert failed[0].startswith("failed: line 3 (") and "missing.wav" in failed[0] and "not found" in failed[0]
    assert failed[1].startswith("failed: line 5 (") and "no_such_emotion" in failed[1]
    assert failed[2].startswith("failed: line 6 (") and "also written by line 2" in failed[2]
    rep = json.loads(report_path.read_text())
    assert (rep["total"], rep["succeeded"], rep["failed"], rep["skipped"]) == (5, 2, 3, 0)
    assert [x["line"] for x in rep["lines"]] == [2, 3, 4, 5, 6]
    assert [x["status"] for x in rep["lines"]] == ["ok", "failed", "ok", "failed", "failed"]

    # Same content as the engine's own result for that line.
    ref = analyze(lines_dir / "bob_map.wav", (lines_dir / "bob_map.txt").read_text(), LineSettings.of(emotion="angry"))
    got = json.loads((lines_dir / "bob_map.json").read_text())
    assert got.pop("produced_by")["row"] == {"audio": "bob_map.wav", "transcript": "bob_map.txt", "emotion": "angry"}
    assert got == json.loads(json.dumps(ref.to_dict(), separators=(",", ":")))
    ref.write_csv(tmp_path / "ref.csv")
    assert (lines_dir / "bob_map.csv").read_text() == (tmp_path / "ref.csv").read_text()
    assert _words(lines_dir / "fast_bilabials.json") == ["maybe", "bobby", "makes", "pumpkin", "pie", "baby"]


def test_rerun_skips_up_to_date_lines_redoes_changed_ones_and_force(lines_dir):
    (lines_dir / "m.csv").write_text("audio,transcript\nbob_map.wav,bob_map.txt\nsub/hello.wav,sub/hello.txt\n")
    first = batch.run(lines_dir / "m.csv", workers=1, progress=False)
    assert first.ok and first.count("ok") == 2
    out = lines_dir / "bob_map.json"
    stamp = out.stat().st_mtime_ns
    again = batch.run(lines_dir / "m.csv", workers=1, progress=False)
    assert again.count("skipped") == 2 and again.count("ok") == 0
    assert out.stat().st_mtime_ns == stamp
    # An edited transcript makes its line stale; the other stays skipped.
    (lines_dir / "bob_map.txt").write_text("Bob bought the map.\n")
    third = batch.run(lines_dir / "m.csv", workers=1, progress=False)
    assert [o.status for o in third.outcomes] == ["ok", "skipped"]
    assert batch.run(lines_dir / "m.csv", workers=1, force=True, progress=False).count("ok") == 2


def test_one_bad_line_does_not_stop_the_pool(lines_dir, tmp_path):
    (lines_dir / "bad.wav").write_bytes(b"RIFF\x00\x00not really a wave file")
    (lines_dir / "m.jsonl").write_text("\n".join(json.dumps(x) for x in [
        {"audio": "bad.wav", "text": "hello"},
        {"audio": "bob_map.wav", "transcript": "bob_map.txt", "fps": "29.97"},
        {"audio": "sub/hello.wav", "text": "", "transcript": "sub/nothing.txt", "output": "x"},
        {"audio": "fast_bilabials.wav", "transcript": "fast_bilabials.txt", "fps": "fast"},
        {"audio": "sub/hello.wav", "transcript": "sub/hello.txt"},
    ]) + "\n")
    seen = []
    rep = batch.run(lines_dir / "m.jsonl", workers=2, out_dir=str(tmp_path / "o"), progress=False,
                    on_outcome=seen.append)
    assert sorted(o.number for o in seen) == [1, 2, 3, 4, 5]
    status = {o.number: o.status for o in rep.outcomes}
    assert status == {1: "failed", 2: "ok", 3: "failed", 4: "failed", 5: "ok"}
    errors = {o.number: o.error for o in rep.failures()}
    assert "transcript file not found" in errors[3]
    assert "frame rate 'fast'" in errors[4]
    assert all("\n" not in e for e in errors.values())
    assert json.loads((tmp_path / "o" / "bob_map.json").read_text())["fps"] == pytest.approx(30000 / 1001)
    assert (tmp_path / "o" / "sub" / "hello.json").is_file()     # mirrors the manifest's folders
    assert not list(tmp_path.rglob("*.part*"))


def test_manifest_errors_are_one_line(tmp_path):
    empty = tmp_path / "e.csv"
    empty.write_text("")
    r = _cli("batch", empty)
    assert r.returncode == 1 and r.stderr.strip() == f"error: manifest {empty} is empty"
    r = _cli("batch", tmp_path / "nope.csv")
    assert r.returncode == 1 and r.stderr.startswith("error: cannot read manifest") and "Traceback" not in r.stderr
    noaudio = tmp_path / "n.csv"
    noaudio.write_text("file,words\na.wav,hi\n")
    r = _cli("batch", noaudio)
    assert r.returncode == 1 and "'audio' column" in r.stderr


def test_progress_bar_only_on_a_terminal(lines_dir, capsys):
    (lines_dir / "m.csv").write_text("audio\nbob_map.wav\n")
    batch.run(lines_dir / "m.csv", workers=1, progress=None)       # stderr is not a terminal under pytest
    assert capsys.readouterr().err == ""
    batch.run(lines_dir / "m.csv", workers=1, progress=True, force=True)
    err = capsys.readouterr().err
    assert "1/1" in err and "line/s" in err


# ---------------------------------------------------------------------------
# Dask

def test_dask_cluster_with_a_worker_killed_mid_run(lines_dir, tmp_path):
    import distributed   # pinned in requirements.txt: CI must run this test, not skip it
    names = [("bob_map.wav", "bob_map.txt"), ("fast_bilabials.wav", "fast_bilabials.txt"),
             ("sub/hello.wav", "sub/hello.txt")]
    rows = [{"audio": a, "transcript": t, "output": f"res/l{k:02d}"} for k in range(24)
            for a, t in [names[k % 3]]]
    (lines_dir / "m.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))

    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None, worker_dashboard_address=None) as cluster, \
            distributed.Client(cluster, timeout=60) as client:
        killed = []

        def kill_one_busy_worker(outcome):
            if killed:
                return
            busy = [w for w, tasks in client.processing().items() if tasks]
            if busy:
                killed.append(busy[0])
                try:
                    client.run(os._exit, 1, workers=[busy[0]], nanny=False, on_error="ignore")
                except Exception:  # noqa: BLE001 - the worker went away mid-call, as intended
                    pass   # the worker went away mid-call, as intended

        seen = []

        def on_outcome(o):
            seen.append(o.number)
            kill_one_busy_worker(o)

        rep = _with_timeout(120, lambda: batch.run(lines_dir / "m.jsonl", scheduler=client, progress=False,
                                                  on_outcome=on_outcome))
        gone = killed and killed[0] not in client.scheduler_info()["workers"]
    assert killed, "no worker was busy to kill"
    assert gone, "the killed worker is still registered"
    assert rep.ok, rep.failure_lines()
    assert sorted(seen) == list(range(1, 25))            # each line reported exactly once
    written = sorted(p.name for p in (lines_dir / "res").iterdir())
    assert written == [f"l{k:02d}.json" for k in range(24)]
    refs = {}
    for k, row in enumerate(rows):
        if row["audio"] not in refs:
            refs[row["audio"]] = analyze(lines_dir / row["audio"], (lines_dir / row["transcript"]).read_text())
        got = json.loads((lines_dir / "res" / f"l{k:02d}.json").read_text())
        ref = refs[row["audio"]].to_dict()
        assert got["words"] == json.loads(json.dumps(ref["words"]))
        assert np.allclose(got["frames"]["weights"], ref["frames"]["weights"])


def _with_timeout(seconds, fn):
    """Run ``fn`` in a thread; fail the test (rather than hang CI) after ``seconds``."""
    import concurrent.futures

    ex = concurrent.futures.ThreadPoolExecutor(1)
    try:
        return ex.submit(fn).result(timeout=seconds)
    finally:
        ex.shutdown(wait=False)


def test_unreachable_scheduler_is_one_clear_error(lines_dir):
    (lines_dir / "m.csv").write_text("audio\nbob_map.wav\n")
    r = _cli("batch", lines_dir / "m.csv", "--scheduler", "tcp://127.0.0.1:9", "--cluster-timeout", "5")
    assert r.returncode == 1
    assert r.stderr.startswith("error: cannot reach the Dask scheduler at tcp://127.0.0.1:9")
    assert "Traceback" not in r.stderr


def test_a_worker_process_keeps_blas_to_one_thread():
    """A batch's worker processes run one line each at a time on a core of their own: numpy's BLAS
    is held to one thread there (its threads would spin on the other workers' cores)."""
    code = ("import threadpoolctl\n"
            "from addon.engine import batch\n"
            "def blas():\n"
            "    return max(i['num_threads'] for i in threadpoolctl.threadpool_info() if i['user_api'] == 'blas')\n"
            "before = blas()\n"
            "batch._pool_init(None)\n"
            "print(before, blas())\n")
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "2", "OMP_NUM_THREADS": "2", "MKL_NUM_THREADS": "2"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120,
                         cwd=Path(__file__).resolve().parents[1])
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["2", "1"]
