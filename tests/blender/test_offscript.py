"""Blender's report after Generate says how far the take strayed from its script."""

from __future__ import annotations

import os
import shutil
from importlib import import_module

import bpy
import pytest

from conftest import MODULE, add_strip, fcurve_values, keyed_shape_keys

HELLO = os.path.join(os.path.dirname(__file__), "..", "..", "sample_rigs", "speech", "hello.wav")


def test_report_counts_words_not_heard(scene, tmp_path, capsys):
    shutil.copy(HELLO, tmp_path / "line.wav")
    command = import_module(MODULE + ".blender.command")
    with open(HELLO[:-4] + ".txt", encoding="utf-8") as fh:
        text = fh.read().strip()
    assert command.execute(["--audio", str(tmp_path / "line.wav"), "--mesh", "Ada", "--text",
                            text + " purple elephants dance quietly tonight"]) == 0
    out = capsys.readouterr().out
    assert "5 words not heard" in out
    assert "'elephants'" in out
    assert keyed_shape_keys(bpy.data.objects["Ada"])


def _strip_without_transcript(scene, tmp_path):
    """hello.wav as a sound strip with no transcript anywhere (no .txt beside it)."""
    shutil.copy(HELLO, tmp_path / "line.wav")
    st = scene.emotive_lipsync
    st.text, st.text_block = "", None
    strip = add_strip(scene, "line", str(tmp_path / "line.wav"), frame=1)
    st.strip, st.target = strip.name, bpy.data.objects["Ada"]
    return strip


def test_generate_without_a_transcript_recognises_the_words(scene, tmp_path):
    panel = import_module(MODULE + ".blender.panel")
    _strip_without_transcript(scene, tmp_path)
    assert panel.problems(bpy.context) == []           # Generate is not held back
    assert "recognised from the audio" in panel.checklist(bpy.context)[1]
    assert bpy.ops.emotive_lipsync.generate("EXEC_DEFAULT", mesh="Ada") == {"FINISHED"}
    ada = bpy.data.objects["Ada"]
    moving = 0
    for name in keyed_shape_keys(ada):
        frames, values = fcurve_values(ada, name)
        moving += values.max() > 0.3
        assert values[(frames - 1) / 30.0 > 6.05].max(initial=0.0) <= 0.05, name   # at rest after the line
    assert moving >= 6                                    # the mouth follows the recognised speech
    assert fcurve_values(ada, "MBP")[1].max() >= 0.9      # and closes on its /p b m/


def test_a_transcript_written_later_is_used_instead(scene, tmp_path):
    panel = import_module(MODULE + ".blender.panel")
    _strip_without_transcript(scene, tmp_path)
    (tmp_path / "line.txt").write_text("Hello! My name is Bob.", encoding="utf-8")
    assert panel.checklist(bpy.context)[1] == ""
    (tmp_path / "line.txt").write_text("  \n", encoding="utf-8")      # emptied: the panel reads it again
    assert "recognised from the audio" in panel.checklist(bpy.context)[1]


def test_command_line_without_a_transcript_says_the_words_were_recognised(scene, tmp_path, capsys):
    shutil.copy(HELLO, tmp_path / "line.wav")
    command = import_module(MODULE + ".blender.command")
    assert command.execute(["--audio", str(tmp_path / "line.wav"), "--mesh", "Ada"]) == 0
    out = capsys.readouterr().out
    assert "words recognised (no transcript)" in out, out
    assert "MBP" in keyed_shape_keys(bpy.data.objects["Ada"])


def test_a_line_in_another_language_without_a_transcript_is_refused_and_changes_nothing(scene, tmp_path, capsys):
    panel = import_module(MODULE + ".blender.panel")
    _strip_without_transcript(scene, tmp_path)
    scene.emotive_lipsync.language = "de"
    assert any("a line in German needs one" in p for p in panel.problems(bpy.context))
    with pytest.raises(RuntimeError, match="a line in German needs its transcript"):
        bpy.ops.emotive_lipsync.generate("EXEC_DEFAULT", mesh="Ada")
    command = import_module(MODULE + ".blender.command")
    assert command.execute(["--audio", str(tmp_path / "line.wav"), "--mesh", "Ada", "--language", "de"]) == 1
    assert "a line in German needs its transcript" in capsys.readouterr().err
    assert keyed_shape_keys(bpy.data.objects["Ada"]) == set()
