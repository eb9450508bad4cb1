"""Every ``blender [-b FILE.blend] --command lipsync ...`` line the README
and the guide show, run as Blender runs it: the file opened, then the
extension's command given the arguments after ``--command lipsync``, in
the folder the command is typed in.

The files the lines name are made here: ``scene.blend`` holds the toy heads
of ``sample_rigs/build_rigs.py`` as ``Bob`` (a viseme per shape key) and
``Ann`` (ARKit keys) and a sound strip ``Bob_l07`` (its transcript the
``.txt`` beside its audio); ``lines/`` holds recorded lines with their
``.txt`` (:data:`LINES`); a page's declared files (``<!-- file:
lines.csv -->``) are written as they are shown.  A line naming another
.blend file or other files fails here, so a new command in the docs gets
its files with it.  The engine's tests (``tests/test_docs.py``) check that
this test covers every such line."""

from __future__ import annotations

import importlib.util
import os
import shutil
import sys
from importlib import import_module

import bpy
import pytest

from conftest import FIXTURES, MODULE, ROOT, SAMPLE, add_strip, build_rigs

_spec = importlib.util.spec_from_file_location("doccommands", os.path.join(ROOT, "tests", "doccommands.py"))
doccommands = sys.modules.setdefault("doccommands", importlib.util.module_from_spec(_spec))
_spec.loader.exec_module(doccommands)

COMMANDS = doccommands.blender_commands()
BOB = os.path.join(FIXTURES, "bob_map.wav")
#: lines/NAME.wav (and its .txt) -> the recording it is.
LINES = {"l01": BOB, "l02": os.path.join(FIXTURES, "fast_bilabials.wav"), "bob_01": BOB, "ann_01": SAMPLE}


def _scene_blend(folder) -> str:
    """``scene.blend``: Bob and Ann, and Bob's strip Bob_l07, at 30 fps."""
    bpy.ops.wm.read_homefile(use_empty=True)
    build_rigs.build_scene_objects()
    bpy.data.objects["Ada"].name = "Bob"
    bpy.data.objects["Kit"].name = "Ann"
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = 30, 1.0
    add_strip(scene, "Bob_l07", BOB, frame=1)
    path = os.path.join(folder, "scene.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    return path


def _world(folder, page: str) -> dict[str, str]:
    """The files the page's commands name, made in ``folder``: .blend name -> path."""
    os.makedirs(os.path.join(folder, "lines"))
    for name, audio in LINES.items():
        shutil.copy(audio, os.path.join(folder, "lines", name + ".wav"))
        shutil.copy(os.path.splitext(audio)[0] + ".txt", os.path.join(folder, "lines", name + ".txt"))
    for name, content in doccommands.files(page).items():
        with open(os.path.join(folder, name), "w", encoding="utf-8") as fh:
            fh.write(content)
    return {"scene.blend": _scene_blend(folder)}


@pytest.mark.parametrize("command", COMMANDS, ids=[c.where for c in COMMANDS])
def test_documented_command(extension, command, tmp_path, monkeypatch, capsys):
    blend, argv = doccommands.blender_argv(command.text)
    blends = _world(str(tmp_path), command.page)
    monkeypatch.chdir(tmp_path)
    if blend is None:
        bpy.ops.wm.read_homefile(use_empty=True)
    else:
        assert blend in blends, f"{command.where}: no {blend} is made for this test"
        assert bpy.ops.wm.open_mainfile(filepath=blends[blend]) == {"FINISHED"}
    code = import_module(MODULE + ".blender.command").execute(argv)
    said = capsys.readouterr()
    assert code == 0, f"{command.where}: `{command.text}` exited with {code}\n{said.out[-2000:]}\n{said.err[-2000:]}"
    if "--help" in argv:
        assert "--command lipsync" in said.out
    else:
        assert "lip-synced, 0 problems" in said.out, said.out
    for flag in ("--save", "--output"):
        if flag in argv:
            saved = blends[blend] if flag == "--save" else os.path.join(tmp_path, argv[argv.index(flag) + 1])
            assert os.path.isfile(saved) and f"lipsync: saved {saved}" in said.out, said.out
