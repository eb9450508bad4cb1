"""The expression layer on real rigs: each preset drives the brow, eye,
cheek and mouth keys of its action units on ARKit and VRoid heads, the lips
still meet on every /p b m/ (measured on the evaluated geometry), the
user's own animation on an expression key is left alone, and a rig with no
expression keys animates as before."""

from __future__ import annotations

import os
from dataclasses import replace
from importlib import import_module

import bpy
import numpy as np
import pytest

from conftest import FIXTURES, MODULE, fcurve_values, keyed_shape_keys
from heads import FPS, HEADS, build_head, measure

PIE = os.path.join(FIXTURES, "fast_bilabials.wav")
PIE_TEXT = "Maybe Bobby makes pumpkin pie, baby."
EMOTIONS = ("happy", "sad", "angry", "surprised", "afraid", "disgusted")


def _mod(name):
    return import_module(f"{MODULE}.{name}")


@pytest.fixture
def empty_scene(extension):
    """An empty scene; the gestures (which raise the brows too) off, so that
    the keys are the speech's and the expression's (tests/blender/test_gestures.py has them)."""
    bpy.ops.wm.read_homefile(use_empty=True)
    sc = bpy.context.scene
    sc.render.fps, sc.render.fps_base = FPS, 1.0
    sc.emotive_lipsync.gestures = False
    return sc


@pytest.fixture(scope="module")
def pie(extension):
    """The line's audio and its alignment, made once: each preset then
    renders from the same alignment (the keys are written as a run does)."""
    audio = _mod("blender.sources").decode(PIE)
    return audio, _mod("engine.pipeline").align_audio(audio, PIE_TEXT)


def _key(scene, obj, pie, emotion, plan=None):
    """Key ``obj`` under ``emotion`` from frame 1 the way a run does; the Summary."""
    run, sources = _mod("blender.run"), _mod("blender.sources")
    audio, al = pie
    if plan is None:
        line = sources.LineInputs(obj, sources.Clip(audio, 1, "pie", PIE), PIE_TEXT)
        plan = run.plan(scene, line, run.options(scene, emotion=emotion))
    else:
        plan = replace(plan, options=replace(plan.options, line=plan.options.line.replace(emotion=emotion)))
    result = _mod("engine.pipeline").analyze(audio, settings=plan.options.line, alignment=al)
    return plan, run.key(obj, plan, run.Analysis(result, 0.0))


def _speaking(al):
    """The frames of the line's speech, away from its /p b m/ (where the
    lower face gives way to the closing lips)."""
    frames = np.arange(int(al.phones[0].start * FPS) + 1, int(al.phones[-1].end * FPS) + 1)
    t = (frames - 1) / FPS
    near = np.zeros(len(t), dtype=bool)
    for p in al.phones:
        if p.phone in ("P", "B", "M"):
            near |= (t > p.start - 0.05) & (t < p.end + 0.05)
    return frames[~near]


@pytest.mark.parametrize("head", ["arkit", "vroid"])
def test_each_preset_drives_its_units_and_the_lips_still_close(empty_scene, pie, head):
    keys, open_key = HEADS[head]
    obj = build_head("Face", keys)
    presets = _mod("engine.presets")
    conventions = _mod("engine.conventions")
    face = conventions.expression_match(list(obj.data.shape_keys.key_blocks.keys()), conventions.load_all())
    speech_keys = None
    for emotion in EMOTIONS:
        plan, summary = _key(empty_scene, obj, pie, emotion)
        speech_keys = speech_keys or {k for mix in plan.mapping.values() for k in mix}
        units = set(presets.load(emotion).expression)
        # Units the head has no key for are named (the brows' lift on pitch accents among them).
        assert units - set(face.mapping) <= set(summary.no_key) and not set(summary.no_key) & set(face.mapping)
        speaking = _speaking(pie[1])
        for unit in units & set(face.mapping):
            assert unit in summary.expression
            for shape_key in face.mapping[unit]:
                frames, values = fcurve_values(obj, shape_key)
                mean = values[np.isin(frames, speaking)].mean()
                assert mean >= 0.2, (emotion, unit, shape_key, mean)
        if summary.no_key:
            assert "no shape key shows " + ", ".join(summary.no_key) in summary.message()
        closed, vowels, lowest = measure(obj, open_key, pie[1].phones)
        assert len(closed) >= 8 and closed.max() <= 0.05, (emotion, np.round(closed, 3))
        assert lowest >= -0.05, (emotion, lowest)
        # Open vowels open under every preset; sad articulates least (the "o" of the fast "Bobby",
        # 72 ms between two closures, opens about 0.11 of the way under it).
        assert vowels.min() >= 0.1 and vowels.max() >= 0.15, (emotion, np.round(vowels, 3))
    # Neutral has no expression: the keys only expressions drive lose what the
    # last emotion keyed on this line.
    _plan, summary = _key(empty_scene, obj, pie, "neutral")
    assert summary.expression == [] and summary.no_key == []
    only_face = {k for mix in face.mapping.values() for k in mix} - speech_keys
    for shape_key in only_face:
        got = fcurve_values(obj, shape_key)
        assert got is None or len(got[0]) == 0, shape_key


def test_the_users_keys_on_expression_keys_win_and_clear_leaves_them(empty_scene, pie):
    keys, _open = HEADS["arkit"]
    obj = build_head("Face", keys)
    kb = obj.data.shape_keys.key_blocks["browDownLeft"]
    for frame, value in ((5, 0.9), (40, 0.1)):
        kb.value = value
        kb.keyframe_insert("value", frame=frame)
    driver = obj.data.shape_keys.key_blocks["eyeSquintRight"].driver_add("value")
    driver.driver.expression = "0.25"
    _plan, summary = _key(empty_scene, obj, pie, "angry")
    assert summary.kept == ["browDownLeft", "eyeSquintRight"]
    assert "kept your animation on browDownLeft, eyeSquintRight" in summary.message()
    frames, values = fcurve_values(obj, "browDownLeft")
    assert list(frames) == [5.0, 40.0] and np.allclose(values, [0.9, 0.1])
    assert fcurve_values(obj, "eyeSquintRight") is None
    assert fcurve_values(obj, "browDownRight")[1].max() >= 0.4     # its other side is lip sync's
    assert bpy.ops.emotive_lipsync.clear(mesh="Face") == {"FINISHED"}
    frames, values = fcurve_values(obj, "browDownLeft")
    assert list(frames) == [5.0, 40.0] and np.allclose(values, [0.9, 0.1])
    assert keyed_shape_keys(obj) == {"browDownLeft"}


def test_a_rig_without_expression_keys_animates_as_before(empty_scene, pie):
    keys, _open = HEADS["oculus"]
    obj = build_head("Face", keys)
    plan, summary = _key(empty_scene, obj, pie, "angry")
    assert summary.expression == [] and {"AU4", "AU5", "AU7", "AU23"} <= set(summary.no_key)
    keyed = {k: fcurve_values(obj, k)[1].copy() for k in keyed_shape_keys(obj)}
    assert set(keyed) == {k for mix in plan.mapping.values() for k in mix}
    # The same run with no expression at all keys exactly the same values.
    conventions = _mod("engine.conventions")
    _key(empty_scene, obj, pie, "angry", replace(plan, expression=conventions.ExpressionMatch({})))
    for k, values in keyed.items():
        assert np.array_equal(fcurve_values(obj, k)[1], values), k
    # Ready Player Me speaks with its Oculus visemes and shows the face on its ARKit keys.
    rpm = build_head("Avatar", HEADS["ready_player_me"][0])
    _plan, summary = _key(empty_scene, rpm, pie, "happy")
    assert {"AU6", "AU12"} <= set(summary.expression) and summary.no_key == []
    assert {"cheekSquintLeft", "mouthSmileRight"} <= keyed_shape_keys(rpm)
    assert not any(k.startswith("jaw") or k == "mouthClose" for k in keyed_shape_keys(rpm))


@pytest.mark.parametrize("head", ["arkit", "vroid"])
def test_the_keys_written_are_the_engines_channels_and_nothing_else(empty_scene, pie, head):
    """The Blender layer writes what the engine's keying step gives it
    (engine/keys.py, tested there): every channel on every frame of the
    line, a key per frame, and no other shape key; the user's own keys
    stay out of it."""
    obj = build_head("Face", HEADS[head][0])
    conventions = _mod("engine.conventions")
    face = conventions.expression_match(list(obj.data.shape_keys.key_blocks.keys()), conventions.load_all())
    # The user's own keys: on a cheek key of the expression's (ARKit), on the eyelids (VRoid).
    kb = obj.data.shape_keys.key_blocks[sorted(face.mapping["AU6"])[0] if head == "arkit" else "Fcl_EYE_Close"]
    kb.value = 0.3
    kb.keyframe_insert("value", frame=20)
    empty_scene.emotive_lipsync.gestures = True
    plan, _summary = _key(empty_scene, obj, pie, "happy")
    result = _mod("engine.pipeline").analyze(pie[0], settings=plan.options.line, alignment=pie[1])
    keys = _mod("engine.keys")
    line = keys.mesh_keys(result, plan.mapping, plan.closure, plan.expression.mapping, animated={kb.name})
    # ... with the gestures on the keys they find (blinks, the brows on the expression's keys).
    line = keys.with_gestures(line, result.gestures, _mod("blender.gestures").channels(obj),
                              plan.expression.mapping, animated={kb.name}, head_elsewhere=True)
    assert line.gesture_keys or line.gesture_kept
    assert line.units and {c.drivers for c in line.channels} >= {("speech",), ("expression",)}
    assert line.kept == ([kb.name] if head == "arkit" else [])
    assert kb.name in line.gesture_kept or kb.name not in _mod("blender.gestures").channels(obj).shape_keys.values()
    assert keyed_shape_keys(obj) == set(line.names) | {kb.name} and kb.name not in line.names
    for c in line.channels:
        frames, values = fcurve_values(obj, c.name)
        assert np.array_equal(frames, 1 + np.arange(line.frames)), c.name
        assert np.allclose(values, c.values, atol=1e-6), c.name      # F-curves hold 32-bit floats
    assert list(fcurve_values(obj, kb.name)[0]) == [20.0]


@pytest.fixture(scope="module")
def human_head(extension):
    """The human sample head's module, its assets fetched as ``./setup.sh`` fetches them."""
    import human

    human.assets()
    return human


@pytest.mark.parametrize("emotion", ("neutral",) + EMOTIONS)
def test_lips_close_under_every_preset_on_the_human_head(empty_scene, pie, human_head, emotion):
    """The human head's ARKit keys are sculpted: its smile and its lip
    tightener press the closed lips together themselves, so on /p b m/ the
    closing pose presses them no further, and they meet without passing
    through each other (the lips' own vertices measured, as in test_human)."""
    obj = human_head.build("Head", "arkit")
    _plan, summary = _key(empty_scene, obj, pie, emotion)
    assert set(_mod("engine.presets").load(emotion).expression) <= set(summary.expression)
    g = obj.vertex_groups["lips"].index
    lips = [v.index for v in obj.data.vertices if any(e.group == g for e in v.groups)]
    closed, vowels, lowest = measure(obj, "jawOpen", pie[1].phones, among=lips)
    assert len(closed) >= 8 and closed.max() <= 0.05, (emotion, np.round(closed, 3))
    assert lowest >= -0.05, (emotion, lowest)
    # Open vowels still open (sad articulates least: about 0.10 to 0.22 of a wide-open jaw on this line,
    # the least on the "o" of the fast "Bobby", 72 ms between two closures).
    assert vowels.min() >= 0.08 and vowels.max() >= 0.15, (emotion, np.round(vowels, 3))


def test_the_panel_names_the_units_a_face_has_no_key_for(empty_scene, pie):
    """The preset's numbers in the panel mark the units the face cannot
    show: the same units a run's report names."""
    panel = _mod("blender.panel")
    arkit = build_head("Face", HEADS["arkit"][0])
    assert panel.units_without_key(arkit) == []
    oculus = build_head("Oculus", HEADS["oculus"][0])
    assert panel.units_without_key(oculus) == list(_mod("engine.expression").units())
    vroid = build_head("Vroid", HEADS["vroid"][0])
    missing = panel.units_without_key(vroid)
    assert missing and "AU4" not in missing        # Fcl_BRW_Angry lowers its brows
    for emotion in ("angry", "surprised"):
        _plan, summary = _key(empty_scene, vroid, pie, emotion)
        units = set(_mod("engine.presets").load(emotion).expression)
        assert units & set(missing) <= set(summary.no_key) <= set(missing), emotion
