"""A batch rerun redoes a line whenever anything that shapes its output has
changed (its files' contents, its manifest row, the command's options, a
preset, viseme set, dictionary or arousal model it uses, the engine) and
only then; outputs
under ``--out DIR`` stay under DIR; a missing audio file is named as such."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from addon.engine import batch
from addon.engine.batch import records
from addon.engine.settings import LineSettings

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


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "addon", *map(str, args)], cwd=ROOT, capture_output=True,
                          text=True, timeout=300)


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


def test_other_options_redo_every_line_and_say_why(lines_dir):
    m = lines_dir / "m.csv"
    m.write_text("audio,transcript\nbob_map.wav,bob_map.txt\nfast_bilabials.wav,fast_bilabials.txt\n")
    r = _cli("batch", m, "--workers", "2")           # records made by the pool's workers
    assert r.returncode == 0, r.stderr
    assert "2 done" in r.stdout
    first = _doc(lines_dir / "bob_map.json")
    assert (first["emotion"], first["viseme_set"], first["fps"]) == ("neutral", "default", 30.0)

    r = _cli("batch", m, "--workers", "1", "--emotion", "sad", "--viseme-set", "oculus", "--fps", "60")
    assert r.returncode == 0, r.stderr
    assert "2 done" in r.stdout and "0 up to date" in r.stdout
    assert "2 redone: settings changed" in r.stdout
    for name in ("bob_map", "fast_bilabials"):
        doc = _doc(lines_dir / f"{name}.json")
        assert (doc["emotion"], doc["viseme_set"], doc["fps"]) == ("sad", "oculus", 60.0)
        assert doc["produced_by"]["settings"]["emotion"] == "sad"

    r = _cli("batch", m, "--workers", "2", "--emotion", "sad", "--viseme-set", "oculus", "--fps", "60")
    assert r.returncode == 0 and "0 done, 2 up to date" in r.stdout and "redone" not in r.stdout
    # Back to the defaults: redone again, not taken for the first run's outputs.
    r = _cli("batch", m, "--workers", "1")
    assert "2 done" in r.stdout
    assert _doc(lines_dir / "bob_map.json")["emotion"] == "neutral"


@pytest.mark.parametrize("option, value", [("coarticulation", "rules"), ("emotion_fade", 0.05)])
def test_each_option_counts(lines_dir, option, value):
    m = lines_dir / "m.csv"
    m.write_text("audio,transcript\nbob_map.wav,bob_map.txt\n")
    assert _status(_run(m)) == ["ok"]
    changed = LineSettings.of(**{option: value})
    again = _run(m, defaults=changed)
    assert _status(again) == ["ok"] and again.outcomes[0].reason == "settings changed"
    assert _status(_run(m, defaults=changed)) == ["skipped"]


def test_a_changed_manifest_row_redoes_that_line_only(lines_dir):
    m = lines_dir / "m.csv"
    m.write_text("audio,transcript,emotion\nbob_map.wav,bob_map.txt,angry\nfast_bilabials.wav,fast_bilabials.txt,\n")
    assert _status(_run(m)) == ["ok", "ok"]
    assert _doc(lines_dir / "bob_map.json")["emotion"] == "angry"
    m.write_text("audio,transcript,emotion\nbob_map.wav,bob_map.txt,happy\nfast_bilabials.wav,fast_bilabials.txt,\n")
    again = _run(m)
    assert _status(again) == ["ok", "skipped"]
    assert again.outcomes[0].reason == "manifest row changed"
    assert _doc(lines_dir / "bob_map.json")["emotion"] == "happy"
    assert "1 redone: manifest row changed" in again.summary()
    # An inline text edit is a row change too.
    m.write_text("audio,text\nbob_map.wav,Bob bought a map\n")
    assert _status(_run(m)) == ["ok"]
    assert _status(_run(m)) == ["skipped"]


def test_edited_preset_viseme_set_and_dictionary_files_redo_the_line(lines_dir):
    presets_dir = lines_dir / "presets"
    presets_dir.mkdir()
    grumpy = presets_dir / "grumpy.json"
    grumpy.write_text(json.dumps({"name": "grumpy", "base": "angry", "gain": 0.9}))
    vset = lines_dir / "mine.json"
    vset.write_text((ROOT / "addon/engine/data/visemes/oculus.json").read_text())
    dic = lines_dir / "words.dict"
    dic.write_text("BOB  B AA1 B\n")
    m = lines_dir / "m.csv"
    m.write_text("audio,transcript,emotion,viseme_set\nbob_map.wav,bob_map.txt,presets/grumpy.json,mine.json\n")
    options = LineSettings.of(dictionary=str(dic))
    assert _status(_run(m, defaults=options)) == ["ok"]
    assert _status(_run(m, defaults=options)) == ["skipped"]

    _replace_with_older(grumpy, json.dumps({"name": "grumpy", "base": "angry", "gain": 0.5}))
    again = _run(m, defaults=options)
    assert _status(again) == ["ok"] and again.outcomes[0].reason == "preset or viseme set changed"
    rec = _doc(lines_dir / "bob_map.json")["produced_by"]
    assert rec["row"]["emotion"] == "presets/grumpy.json" and rec["settings"]["emotion"] is None

    doc = json.loads(vset.read_text())
    first = next(iter(doc["visemes"]))
    doc["visemes"][first]["range"] = [0.0, 0.5, 0.9]
    _replace_with_older(vset, json.dumps(doc))
    again = _run(m, defaults=options)
    assert _status(again) == ["ok"] and again.outcomes[0].reason == "preset or viseme set changed"

    _replace_with_older(dic, "BOB  B AO1 B\n")
    again = _run(m, defaults=options)
    assert _status(again) == ["ok"] and again.outcomes[0].reason == "dictionary changed"
    assert _status(_run(m, defaults=options)) == ["skipped"]


def test_a_tag_preset_file_counts(lines_dir):
    grumpy = lines_dir / "grumpy.json"
    grumpy.write_text(json.dumps({"name": "grumpy", "base": "angry", "gain": 0.9}))
    m = lines_dir / "m.csv"
    m.write_text(f'audio,text\nbob_map.wav,"Bob bought [{grumpy}] a map."\n')
    assert _status(_run(m)) == ["ok"]
    _replace_with_older(grumpy, json.dumps({"name": "grumpy", "base": "angry", "gain": 0.5}))
    again = _run(m)
    assert _status(again) == ["ok"] and again.outcomes[0].reason == "preset or viseme set changed"


def test_input_contents_count_not_their_times(lines_dir):
    m = lines_dir / "m.csv"
    m.write_text("audio,transcript\nbob_map.wav,bob_map.txt\nfast_bilabials.wav,\n")   # second: the .txt beside it
    assert _status(_run(m)) == ["ok", "ok"]
    # Touched but unchanged: still up to date.
    for p in lines_dir.glob("*.wav"):
        os.utime(p)
    assert _status(_run(m)) == ["skipped", "skipped"]
    # Other words, same size, an older time: redone.
    _replace_with_older(lines_dir / "bob_map.txt", "Rob bought a map.\n")
    again = _run(m)
    assert _status(again) == ["ok", "skipped"] and again.outcomes[0].reason == "input file changed"
    assert [w["word"] for w in _doc(lines_dir / "bob_map.json")["words"]][0] == "rob"
    # The transcript found beside the audio is an input as well.
    txt = lines_dir / "fast_bilabials.txt"
    _replace_with_older(txt, "Maybe Bobby makes a pumpkin pie, baby.\n")
    assert _status(_run(m)) == ["skipped", "ok"]
    # Audio content.
    wav = lines_dir / "bob_map.wav"
    data = bytearray(wav.read_bytes())
    data[-200:] = bytes(b ^ 1 for b in data[-200:])       # the last samples' lowest bit flipped
    _replace_with_older(wav, bytes(data))
    assert _status(_run(m)) == ["ok", "skipped"]
    assert _status(_run(m)) == ["skipped", "skipped"]


def test_unchanged_inputs_are_not_read_again(lines_dir, monkeypatch):
    m = lines_dir / "m.csv"
    m.write_text("audio,transcript\nbob_map.wav,bob_map.txt\n")
    for p in lines_dir.iterdir():                   # files older than the first run, as a studio's are
        old = p.stat().st_mtime_ns - 3600 * 10**9
        os.utime(p, ns=(old, old))
    assert _status(_run(m)) == ["ok"]
    hashed = []
    real = records._file_sha
    monkeypatch.setattr(records, "_file_sha", lambda path: hashed.append(Path(path).name) or real(path))
    assert _status(_run(m)) == ["skipped"]
    assert hashed == []
    os.utime(lines_dir / "bob_map.wav")            # touched: read again, found the same
    assert _status(_run(m)) == ["skipped"]
    assert hashed == ["bob_map.wav"]


@pytest.mark.parametrize("part", ["engine_version", "_engine_data"])
def test_another_engine_redoes_every_line(lines_dir, monkeypatch, part):
    m = lines_dir / "m.csv"
    m.write_text("audio,transcript\nbob_map.wav,bob_map.txt\n")
    assert _status(_run(m)) == ["ok"]
    engine = _doc(lines_dir / "bob_map.json")["produced_by"]["engine"]
    assert engine["version"] == batch.engine_version() != "unknown"
    assert engine["data"] == records._engine_data() != hashlib.sha256().hexdigest()   # the data files, read
    monkeypatch.setattr(records, part, lambda: "other")   # a new release, or the same one with new data files
    again = _run(m)
    assert _status(again) == ["ok"] and again.outcomes[0].reason == "engine changed"
    assert "other" in _doc(lines_dir / "bob_map.json")["produced_by"]["engine"].values()
    assert _status(_run(m)) == ["skipped"]


def test_the_arousal_model_file_counts(lines_dir, monkeypatch):
    model = lines_dir / "arousal.json"
    doc = json.loads((ROOT / "addon/engine/data/arousal.json").read_text())
    model.write_text(json.dumps(doc))
    monkeypatch.setenv("LIPSYNC_AROUSAL_MODEL", str(model))
    m = lines_dir / "m.csv"
    m.write_text("audio,transcript\nbob_map.wav,bob_map.txt\n")
    assert _status(_run(m)) == ["ok"]
    assert _status(_run(m)) == ["skipped"]
    doc["bias"] = float(doc["bias"]) + 0.5
    _replace_with_older(model, json.dumps(doc))
    again = _run(m)
    assert _status(again) == ["ok"] and again.outcomes[0].reason == "arousal model changed"


def test_outputs_without_a_record_are_redone_and_force_stays(lines_dir):
    m = lines_dir / "m.csv"
    m.write_text("audio,transcript\nbob_map.wav,bob_map.txt\n")
    out = lines_dir / "bob_map.json"
    out.write_text('{"schema": 1}')            # made some other way, newer than the inputs
    again = _run(m)
    assert _status(again) == ["ok"] and again.outcomes[0].reason == "no record of what made it"
    assert _status(_run(m)) == ["skipped"]
    forced = _run(m, force=True)
    assert _status(forced) == ["ok"] and forced.outcomes[0].reason is None


def test_csv_outputs_carry_their_record_beside_them(lines_dir):
    m = lines_dir / "m.csv"
    m.write_text("audio,transcript\nbob_map.wav,bob_map.txt\n")
    csv_out = lines_dir / "bob_map.csv"
    assert _status(_run(m, formats=("csv",))) == ["ok"]
    side = Path(str(csv_out) + batch.CSV_RECORD_SUFFIX)
    assert side.is_file() and not (lines_dir / "bob_map.json").exists()
    assert csv_out.read_text().splitlines()[0].startswith("frame,time,")
    assert _status(_run(m, formats=("csv",))) == ["skipped"]
    sad = LineSettings.of(emotion="sad")
    assert _status(_run(m, formats=("csv",), defaults=sad)) == ["ok"]
    assert _doc(side)["settings"]["emotion"] == "sad"
    # JSON and CSV, then JSON alone with other settings: the CSV left behind is stale and is redone.
    assert _status(_run(m, formats=("json", "csv"))) == ["ok"]
    assert _status(_run(m, formats=("json",), defaults=sad)) == ["ok"]
    stale = csv_out.read_text()
    again = _run(m, formats=("json", "csv"), defaults=sad)
    assert _status(again) == ["ok"] and again.outcomes[0].reason == "settings changed"
    assert csv_out.read_text() != stale
    assert again.outcomes[0].outputs == [str(lines_dir / "bob_map.json"), str(csv_out)]


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
