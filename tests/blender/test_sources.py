"""Where a line comes from: one function (sources.line_inputs) answers for
Generate, Generate for All Strips and the batch command, each part from the
first place that has it."""

from __future__ import annotations

import os
from importlib import import_module

import bpy
import pytest

from conftest import FIXTURES, MODULE, add_strip

BOB = os.path.join(FIXTURES, "bob_map.wav")
PIE = os.path.join(FIXTURES, "fast_bilabials.wav")


def _sources():
    return import_module(MODULE + ".blender.sources")


def test_a_strips_own_properties_say_its_target_words_and_language(scene):
    strip = add_strip(scene, "Kit_line", BOB, frame=5)
    block = bpy.data.texts.new("words")
    block.from_string("Bob bought the map.")
    strip["lipsync_text"], strip["lipsync_language"] = "words", "deu"
    line = _sources().line_inputs(scene, strip=strip)
    assert line.target is bpy.data.objects["Kit"]               # the mesh its name starts with
    assert (line.text, line.language, line.clip.first_frame) == ("Bob bought the map.", "de", 5)
    # What the line is given wins over the strip's own.
    given = _sources().line_inputs(scene, strip="Kit_line", target=bpy.data.objects["Ada"], text="Bob.",
                                   language="fr")
    assert (given.target.name, given.text, given.language) == ("Ada", "Bob.", "fr")


def test_the_panels_generate_reads_the_panel_not_the_strips_properties(scene):
    strip = add_strip(scene, "Kit_line", BOB, frame=5)
    block = bpy.data.texts.new("words")
    block.from_string("Bob bought the map.")
    strip["lipsync_text"], strip["lipsync_language"] = "words", "deu"
    ada = bpy.data.objects["Ada"]
    line = _sources().line_inputs(scene, strip="", target=ada, typed="Typed words.", strip_properties=False)
    assert (line.target, line.text, line.language) == (ada, "Typed words.", None)   # the active strip, the panel's
    # With no words in the panel: the .txt beside the audio.
    beside = _sources().line_inputs(scene, strip="Kit_line", target=ada, strip_properties=False)
    assert beside.text == "Bob bought a map.\n" and beside.clip.label == "Kit_line"


def test_an_audio_file_is_keyed_from_its_frame_onto_the_fallback(scene):
    seen = []
    ada = bpy.data.objects["Ada"]
    line = _sources().line_inputs(scene, audio=PIE, frame=40, fallback=ada, on_clip=seen.append)
    assert line.target is ada and line.clip.first_frame == 40 and seen == [line.clip]
    assert line.text == open(os.path.splitext(PIE)[0] + ".txt", encoding="utf-8").read()
    with pytest.raises(Exception, match=r"fast_bilabials\.wav: no mesh \(give a 'mesh' column or --mesh\)$"):
        _sources().line_inputs(scene, audio=PIE, no_target="give a 'mesh' column or --mesh")
    narrator = add_strip(scene, "narrator", BOB, frame=1)
    with pytest.raises(Exception, match=r"^strip 'narrator': no mesh \(name it after the mesh\)$"):
        _sources().line_inputs(scene, strip=narrator, no_target="name it after the mesh")
    with pytest.raises(Exception, match="no sound strip: add one"):
        _sources().line_inputs(bpy.data.scenes.new("Empty"), target=ada)
