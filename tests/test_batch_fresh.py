"""A batch rerun redoes a line whenever anything that shapes its output has
changed (its files' contents, its manifest row, the command's options, a
preset, viseme set or dictionary it uses, the engine) and only then; outputs
under ``--out DIR`` stay under DIR; a missing audio file is named as such."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from addon.engine import batch

ROOT = Path(__file__).resolve().parent.parent
FIX = ROOT / "tests" / "fixtures"


@pytest.fixture
def lines_dir(tmp_path):
    d = tmp_path / "lines"
    d.mkdir()
    for name in ("bob_map", "fast_bilabials"):
        shutil.copy(FIX / f"{name}.wav", d / f"{name}.wav")
        shutil.copy(FIX / f"{name}.txt", d / f"{name}.txt")
    return d


def _cli(*args, cwd=ROOT):
    return subprocess.run([sys.executable, "-m", "addon", *map(str, args)], cwd=cwd, capture_output=True,
                          text=True, timeout=300, env={**os.environ, "PYTHONPATH": str(ROOT)})


def _run(manifest, **kw):
    return batch.run(manifest, kw.pop("defaults", None), workers=1, progress=False, **kw)


def _status(report):
    return [o.status for o in report.outcomes]


def _doc(path):
    return json.loads(Path(path).read_text())


def _replace_with_older(path: Path, content: str | bytes) -> None:
    """Other content, dated an hour before the file it replaces (a take
    restored from a backup): older than the outputs, so times alone miss it."""
    st = path.stat()
    path.write_bytes(content if isinstance(content, bytes) else content.encode())
    old = st.st_mtime_ns - 3600 * 10**9
    os.utime(path, ns=(old, old))



# ---------------------------------------------------------------------------
# --out DIR keeps every output under DIR

def test_out_dir_keeps_outputs_of_audio_outside_the_manifest_folder_under_it(lines_dir, tmp_path):
    sub = lines_dir / "sub"
    sub.mkdir()
    (sub / "m.csv").write_text("audio,transcript\n../bob_map.wav,../bob_map.txt\n"
                               "../sub/../fast_bilabials.wav,../fast_bilabials.txt\n")
    out = tmp_path / "out" / "deep"
    r = _cli("batch", sub / "m.csv", "--out", out, "--workers", "1")
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in out.iterdir()) == ["bob_map.json", "fast_bilabials.json"]
    written = [p for p in tmp_path.rglob("*.json")]
    assert all(out in p.parents for p in written), written

    lines = batch.read_manifest(sub / "m.csv", out_dir=str(out))
    assert [ln.outputs["json"] for ln in lines] == [str(out / "bob_map.json"), str(out / "fast_bilabials.json")]
    # Audio below the manifest's folder keeps its folders; two lines that land on one name are refused.
    (lines_dir / "m.csv").write_text("audio\nsub/x.wav\nsub/../sub/y.wav\n../lines/sub/x.wav\n")
    a, b, c = batch.read_manifest(lines_dir / "m.csv", out_dir=str(out))
    assert a.outputs["json"] == str(out / "sub" / "x.json") and b.outputs["json"] == str(out / "sub" / "y.json")
    assert "also written by line 2" in c.problem


# ---------------------------------------------------------------------------
# a missing audio file

def test_missing_audio_without_a_transcript_says_the_audio_is_missing(lines_dir, tmp_path):
    (lines_dir / "m.csv").write_text("audio\nnope.wav\n")
    rep = _run(lines_dir / "m.csv")
    assert rep.failure_lines() == [f"line 2 ({lines_dir / 'nope.wav'}): audio file not found: {lines_dir / 'nope.wav'}"]

    r = _cli("analyze", tmp_path / "nope.wav", "--json", tmp_path / "o.json")
    assert r.returncode == 1
    assert r.stderr.strip() == f"error: audio file not found: {tmp_path / 'nope.wav'}"
    assert not (tmp_path / "o.json").exists()
