"""Blender's report after Generate says how far the take strayed from its script."""

from __future__ import annotations

import os
import shutil
from importlib import import_module

import bpy

from conftest import MODULE, keyed_shape_keys

HELLO = os.path.join(os.path.dirname(__file__), "..", "..", "sample_rigs", "speech", "hello.wav")


def test_report_counts_words_not_heard(scene, tmp_path, capsys):
    shutil.copy(HELLO, tmp_path / "line.wav")
    command = import_module(MODULE + ".blender.command")
    assert command.execute(["--audio", str(tmp_path / "line.wav"), "--mesh", "Ada", "--text",
                            "Hello! My name is Bob, and I'm very happy to meet you. "
                            "purple elephants dance quietly tonight"]) == 0
    out = capsys.readouterr().out
    assert "5 words not heard" in out
    assert "'elephants'" in out
    assert keyed_shape_keys(bpy.data.objects["Ada"])
