"""Emotion changing inside a strip from ``emotion:<preset>`` timeline
markers, and the voice's arousal kept on the strip by Generate."""

from __future__ import annotations

import json
import os
from importlib import import_module

import bpy
import numpy as np
import pytest

from conftest import FIXTURES, MODULE, add_strip, fcurve_values, keyed_shape_keys

PIE = os.path.join(FIXTURES, "fast_bilabials.wav")


def _curves(obj):
    return {k: fcurve_values(obj, k) for k in sorted(keyed_shape_keys(obj))}


def _run(scene, emotion="neutral"):
    assert bpy.ops.emotive_lipsync.generate("EXEC_DEFAULT", mesh="Ada", emotion=emotion, tolerance=0.0) == \
        {"FINISHED"}
    return _curves(bpy.data.objects["Ada"])


@pytest.fixture
def line(scene):
    strip = add_strip(scene, "line", PIE, frame=11)
    block = bpy.data.texts.new("pie")
    with open(os.path.splitext(PIE)[0] + ".txt", encoding="utf-8") as fh:
        block.from_string(fh.read())
    scene.emotive_lipsync.text_block = block
    folder = import_module(MODULE + ".blender.userdata").folder(create=True)
    path = os.path.join(folder, "hushed.json")
    with open(path, "w", encoding="utf-8") as fh:
        json.dump({"name": "hushed", "base": "neutral", "gain": 0.35}, fh)
    yield strip
    os.remove(path)


def test_marker_switches_the_preset_inside_the_strip(scene, line):
    neutral = _run(scene)
    hushed = _run(scene, "hushed")
    assert -1 <= line["lipsync_arousal"] <= 1            # the estimate is kept on the strip
    mark = 11 + 25                                        # 25 frames into the line, at 30 fps
    scene.timeline_markers.new("emotion:hushed", frame=mark)
    scene.timeline_markers.new("emotion:angry", frame=200)   # after the strip: ignored
    mixed = _run(scene, "neutral")
    fade = round(0.3 * 30)
    moved = False
    for name, (frames, values) in mixed.items():
        n_f, n_v = neutral[name]
        h_f, h_v = hushed[name]
        assert np.array_equal(frames, n_f) and np.array_equal(frames, h_f)
        before, after = frames < mark - fade, frames >= mark
        assert np.allclose(values[before], n_v[before], atol=1e-6)
        assert np.allclose(values[after], h_v[after], atol=1e-6)
        moved |= not np.allclose(n_v[after], h_v[after], atol=1e-3)
        own = np.maximum(np.abs(np.diff(n_v)), np.abs(np.diff(h_v)))
        gap = np.abs(n_v - h_v)
        assert (np.abs(np.diff(values)) <= own + np.maximum(gap[1:], gap[:-1]) / fade + 1e-6).all()
    assert moved


def test_marker_naming_no_preset_is_an_error_and_keys_nothing(scene, line):
    scene.timeline_markers.new("emotion:furius", frame=20)
    with pytest.raises(RuntimeError, match="emotion:furius.*frame 20"):
        bpy.ops.emotive_lipsync.generate("EXEC_DEFAULT", mesh="Ada")
    assert keyed_shape_keys(bpy.data.objects["Ada"]) == set()
    assert "lipsync_arousal" not in line
