"""``blender --command lipsync --manifest lines.csv``: many lines onto many
meshes in one session, through the engine's batch runner."""

from __future__ import annotations

import json
import os
import sys
from importlib import import_module

import bpy

from conftest import FIXTURES, MODULE, SAMPLE, add_strip, fcurve_values

BOB = os.path.join(FIXTURES, "bob_map.wav")
PIE = os.path.join(FIXTURES, "fast_bilabials.wav")


def _command():
    return import_module(MODULE + ".blender.command")


def _frames(obj, key):
    frames, _v = fcurve_values(obj, key)
    return int(frames[0]), int(frames[-1])


def test_manifest_keys_many_meshes_and_reports_bad_lines(scene, tmp_path, capsys, monkeypatch):
    batch = import_module(MODULE + ".engine.batch")
    warmed = []
    real_warm = batch.warm
    monkeypatch.setattr(batch, "warm", lambda *a: (warmed.append(a), real_warm(*a)))
    add_strip(scene, "Ada_pie", PIE, frame=300)
    (tmp_path / "bob.txt").write_text("Bob bought a map.\n")
    manifest = tmp_path / "lines.csv"
    manifest.write_text(
        "audio,mesh,frame,transcript,text,emotion,strip\n"
        f"{BOB},Ada,10,bob.txt,,,\n"                 # transcript relative to the manifest
        f"{PIE},Kit,,,\"Maybe Bobby makes pumpkin pie, baby.\",angry,\n"
        f"{tmp_path / 'nope.wav'},Ada,,,hello,,\n"     # a bad line: the others still run
        ",,,,,,Ada_pie\n"                            # a strip: its mesh by its name, .txt beside its audio
        f"{BOB},Nobody,,,Bob bought a map.,,\n")
    before = {m for m in ("tqdm", "dask", "distributed") if m in sys.modules}
    code = _command().execute(["--manifest", str(manifest)])
    out = capsys.readouterr()
    assert code == 1
    assert "lipsync: 3 of 5 lip-synced, 2 problems" in out.out
    err = [ln for ln in out.err.splitlines() if ln.startswith("lipsync: line")]
    assert len(err) == 2
    assert err[0].startswith("lipsync: line 4: ") and "nope.wav" in err[0]
    assert err[1].startswith("lipsync: line 6: ") and "'Nobody'" in err[1]
    assert len(warmed) == 1                                      # models loaded once for the session
    ada, kit = bpy.data.objects["Ada"], bpy.data.objects["Kit"]
    first, last = _frames(ada, "MBP")
    assert first == 10 and last >= 300                           # line 2 at frame 10, the strip from 300
    k_first, k_last = _frames(kit, "mouthClose")
    assert 10 < k_first < 300 and k_last < 300                   # line 3 placed after line 2
    # Blender's extension bundles neither tqdm nor Dask: the command must not import them.
    assert {m for m in ("tqdm", "dask", "distributed") if m in sys.modules} == before


def test_manifest_json_lines_all_good_and_unreadable_manifest(scene, tmp_path, capsys):
    manifest = tmp_path / "lines.jsonl"
    manifest.write_text("\n".join(json.dumps(x) for x in [
        {"audio": BOB, "mesh": "Ada", "text": "Bob bought a map.", "frame": 1},
        {"audio": SAMPLE, "mesh": "Kit", "viseme_set": "arkit", "frame": 1},
    ]) + "\n")
    out = str(tmp_path / "out.blend")
    assert _command().execute(["--manifest", str(manifest), "--output", out]) == 0
    assert os.path.isfile(out)
    assert _frames(bpy.data.objects["Ada"], "MBP")[0] == 1
    assert _frames(bpy.data.objects["Kit"], "mouthClose")[0] == 1
    assert "2 of 2 lip-synced, 0 problems" in capsys.readouterr().out
    assert _command().execute(["--manifest", str(tmp_path / "missing.csv")]) == 1
    assert "cannot read manifest" in capsys.readouterr().err
    assert _command().execute(["--manifest", str(manifest), "--all-strips"]) == 2   # a usage error


def test_all_strips_run_through_the_batch_runner(scene, capsys, monkeypatch):
    batch = import_module(MODULE + ".engine.batch")
    seen = []
    real = batch.run_inline

    def spy(lines, defaults, fn):
        for out in real(lines, defaults, fn):
            seen.append((out.number, out.status))
            yield out

    monkeypatch.setattr(batch, "run_inline", spy)
    add_strip(scene, "Ada_line1", BOB, frame=1, channel=1)
    add_strip(scene, "Kit_line2", PIE, frame=100, channel=2)
    add_strip(scene, "narrator", BOB, frame=200, channel=3)   # names no mesh
    assert _command().execute(["--all-strips"]) == 1
    assert seen == [(1, "ok"), (2, "ok"), (3, "failed")]
    assert _frames(bpy.data.objects["Ada"], "MBP")[0] == 1
    assert _frames(bpy.data.objects["Kit"], "mouthClose")[0] == 100
    assert "narrator" in capsys.readouterr().err


def test_usage_errors_exit_with_status_2_and_key_nothing(scene, tmp_path, capsys):
    """The exit statuses docs/blender.md gives: 2 when the options themselves are wrong."""
    manifest = tmp_path / "lines.csv"
    manifest.write_text(f"audio,mesh\n{BOB},Ada\n")
    for argv, said in ((["--audio", BOB], "--audio needs --mesh"),
                       (["--manifest", str(manifest), "--all-strips"], "--manifest names every line itself"),
                       (["--manifest", str(manifest), "--audio", BOB, "--mesh", "Ada"], "--manifest names every"),
                       (["--audio", BOB, "--audio", PIE, "--mesh", "Ada", "--text", "Bob"], "exactly one"),
                       (["--audio", BOB, "--mesh", "Ada", "--tolerance", "-0.1"], "negative"),
                       (["--audio", BOB, "--mesh", "Ada", "--tolerance", "lots"], "not a number"),
                       (["--scene", "Nope"], "no scene named 'Nope'"),
                       (["--bogus"], "unrecognized arguments")):
        assert _command().execute(argv) == 2, argv
        assert said in capsys.readouterr().err, argv
    assert bpy.data.objects["Ada"].data.shape_keys.animation_data is None
    # What the options name is another matter: nothing lip-synced is status 1.
    assert _command().execute(["--audio", BOB, "--mesh", "Nobody"]) == 1
    assert "no object named 'Nobody'" in capsys.readouterr().err
