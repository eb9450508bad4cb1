"""Real characters' naming conventions, mapped with one click and checked on
the geometry Blender evaluates: lips together on every /p b m/, never pushed
through each other, open on open vowels."""

from __future__ import annotations

import os
from importlib import import_module

import bpy
import numpy as np
import pytest

from conftest import FIXTURES, MODULE, add_strip, keyed_shape_keys
from heads import HEADS, build_head, measure, span_frames

PIE = os.path.join(FIXTURES, "fast_bilabials.wav")
SLOW_PIE = os.path.join(FIXTURES, "slow_bilabials.wav")
PIE_TEXT = "Maybe Bobby makes pumpkin pie, baby."
SLOW_START = 101   # the slow reading is keyed from this frame
BILABIALS = {"P", "B", "M"}

#: The convention each head must be recognised as.
EXPECTED = {
    "ready_player_me": "oculus", "oculus": "oculus", "vrchat": "vrchat", "arkit": "arkit",
    "arkit_pascal_prefixed": "arkit", "arkit_cc_numbered": "arkit", "vroid": "vroid", "vrm0": "vrm",
    "vrm1": "vrm", "mmd": "vrm", "preston_blair": "preston_blair", "rhubarb": "rhubarb",
    "character_creator_4": "character_creator", "character_creator_3": "character_creator",
    "iclone_direct": "iclone", "mpfb_microsoft": "microsoft", "daz_genesis_8": "daz_genesis",
}


def _convention_label(name):
    return import_module(f"{MODULE}.engine.conventions").load(name).label


def _phones(path):
    decoded = import_module(MODULE + ".blender.sources").decode(path)
    return import_module(MODULE + ".engine.pipeline").align_audio(decoded, PIE_TEXT).phones


@pytest.fixture(scope="module")
def pie_phones(extension):
    return _phones(PIE)


@pytest.fixture(scope="module")
def slow_phones(extension):
    return _phones(SLOW_PIE)


@pytest.mark.parametrize("head", sorted(HEADS))
def test_one_click_maps_every_viseme_and_the_lips_close(empty_scene, pie_phones, slow_phones, head):
    keys, open_key = HEADS[head]
    obj = build_head("Face", keys)
    add_strip(empty_scene, "line", PIE, frame=1)
    # Generate with nothing set up: the convention is detected and stored.
    assert bpy.ops.emotive_lipsync.generate(mesh="Face", text=PIE_TEXT) == {"FINISHED"}
    st = obj.emotive_lipsync
    assert st.convention == _convention_label(EXPECTED[head])
    vset = import_module(MODULE + ".blender.run").mesh_viseme_set(obj)
    assert import_module(MODULE + ".engine.mapping").unmapped(vset, st.mapping_dict()) == []
    keyed = keyed_shape_keys(obj)
    assert open_key in keyed
    # The same line read slowly, keyed later on the same mesh.
    assert bpy.ops.emotive_lipsync.generate(mesh="Face", filepath=SLOW_PIE, frame=SLOW_START,
                                            text=PIE_TEXT) == {"FINISHED"}
    for phones, first in ((pie_phones, 1), (slow_phones, SLOW_START)):
        closed, vowels, lowest = measure(obj, open_key, phones, first)
        assert len(closed) >= 8  # "Maybe Bobby makes pumpkin pie, baby"
        assert closed.max() <= 0.05, f"lips apart at a /p b m/: {np.round(closed, 3)}"
        assert lowest >= -0.05, f"lips pushed through each other ({lowest:.3f})"
        assert len(vowels) >= 2 and vowels.min() >= 0.15 and vowels.max() >= 0.25, \
            f"open vowels barely open: {np.round(vowels, 3)}"


def test_speech_keys_win_over_arkit_on_a_mesh_with_both(empty_scene):
    keys, _open = HEADS["ready_player_me"]
    obj = build_head("Avatar", keys)
    assert bpy.ops.emotive_lipsync.auto_map(mesh="Avatar") == {"FINISHED"}
    driven = {k for mix in obj.emotive_lipsync.mapping_dict().values() for k in mix}
    assert driven == {k for k in keys if k.startswith("viseme_")}  # all 15, no ARKit key
    # The user's explicit choice still wins.
    assert bpy.ops.emotive_lipsync.auto_map(mesh="Avatar", viseme_set="arkit") == {"FINISHED"}
    driven = {k for mix in obj.emotive_lipsync.mapping_dict().values() for k in mix}
    assert "jawOpen" in driven and not any(k.startswith("viseme_") for k in driven)
    assert obj.emotive_lipsync.convention == _convention_label("arkit")


def test_arkit_mouth_close_follows_the_jaw(empty_scene, pie_phones):
    keys, _open = HEADS["arkit"]
    obj = build_head("Face", keys)
    add_strip(empty_scene, "line", PIE, frame=1)
    assert bpy.ops.emotive_lipsync.generate(mesh="Face", text=PIE_TEXT) == {"FINISHED"}
    from conftest import fcurve_values

    frames, close = fcurve_values(obj, "mouthClose")
    _f, jaw = fcurve_values(obj, "jawOpen")
    assert np.all(close <= jaw + 1e-6)  # never above the jaw: lips never pass through each other
    for p in (p for p in pie_phones if p.phone in BILABIALS):
        k = np.array(span_frames(p)) - 1
        assert np.allclose(close[k], jaw[k], atol=0.02)  # equal to the jaw: the lips meet


def test_unknown_names_say_what_is_known(empty_scene):
    build_head("Blob", {"Smile": {"smile": 1.0}, "Blink": {}})
    with pytest.raises(RuntimeError, match="follow a naming convention this add-on knows.*ARKit"):
        bpy.ops.emotive_lipsync.auto_map(mesh="Blob")
    with pytest.raises(RuntimeError, match="match the viseme set 'oculus'"):
        bpy.ops.emotive_lipsync.auto_map(mesh="Blob", viseme_set="oculus")
    blob = bpy.data.objects["Blob"].emotive_lipsync
    assert blob.viseme_set == "AUTO" and len(blob.mapping) == 0  # a failed Auto-Map changes nothing


def test_panel_says_which_convention(empty_scene):
    panel = import_module(MODULE + ".blender.panel")
    keys, _open = HEADS["vroid"]
    obj = build_head("Face", keys)
    assert panel._convention_text(obj) == _convention_label("vroid") + " (detected)"
    assert panel.problems(bpy.context) != []  # no audio yet; but no mapping complaint
    assert not any("Unmapped" in p or "convention" in p for p in panel.problems(bpy.context))
    assert bpy.ops.emotive_lipsync.auto_map(mesh="Face") == {"FINISHED"}
    assert panel._convention_text(obj) == _convention_label("vroid")
    blob = build_head("Blob", {"Smile": {"smile": 1.0}})
    bpy.context.view_layer.objects.active = blob
    assert panel._convention_text(blob) == ""
    assert any("naming convention" in p for p in panel.problems(bpy.context))


def _parented(obj, parent):
    obj.parent = parent
    return obj


def test_the_characters_teeth_move_with_the_face_and_clear_with_it(empty_scene, pie_phones):
    """A Ready Player Me avatar keeps viseme keys on Wolf3D_Head and
    Wolf3D_Teeth under one armature: both are keyed, identically."""
    keys, open_key = HEADS["ready_player_me"]
    rig = bpy.data.objects.new("Armature", bpy.data.armatures.new("Armature"))
    empty_scene.collection.objects.link(rig)
    head = _parented(build_head("Wolf3D_Head", keys), rig)
    teeth = _parented(build_head("Wolf3D_Teeth", {k: {"jaw": 1.0} for k in ("viseme_aa", "viseme_O", "viseme_PP")}),
                      rig)
    stranger = build_head("Other_Head", {"viseme_aa": {"jaw": 1.0}})  # same names, another character
    add_strip(empty_scene, "line", PIE, frame=1)
    assert bpy.ops.emotive_lipsync.generate(mesh="Wolf3D_Head", text=PIE_TEXT) == {"FINISHED"}
    from conftest import fcurve_values

    assert keyed_shape_keys(teeth) == {"viseme_aa", "viseme_O", "viseme_PP"}
    for name in ("viseme_aa", "viseme_O", "viseme_PP"):
        assert np.array_equal(fcurve_values(teeth, name)[1], fcurve_values(head, name)[1])
    assert keyed_shape_keys(stranger) == set()
    assert bpy.ops.emotive_lipsync.clear(mesh="Wolf3D_Head") == {"FINISHED"}
    assert keyed_shape_keys(teeth) == set() and keyed_shape_keys(head) == set()
    # Turned off, only the face is keyed.
    empty_scene.emotive_lipsync.whole_character = False
    assert bpy.ops.emotive_lipsync.generate(mesh="Wolf3D_Head", text=PIE_TEXT) == {"FINISHED"}
    assert keyed_shape_keys(teeth) == set() and "viseme_aa" in keyed_shape_keys(head)


def test_a_studios_own_viseme_set_file_maps_by_its_own_names(empty_scene, tmp_path):
    """A viseme set file of the studio's own: its viseme names (and aliases)
    are the names Auto-Map looks for."""
    import json

    doc = json.loads(open(import_module(MODULE + ".engine.visemes").DATA.joinpath("preston_blair.json"),
                          encoding="utf-8").read())
    doc["name"] = "studio_chart"
    doc["aliases"] = {"AI": ["wide_open"]}
    path = tmp_path / "studio_chart.json"
    path.write_text(json.dumps(doc), encoding="utf-8")
    obj = build_head("Toon", {"rest": {}, "MBP": {"press": 1.0}, "wide_open": {"jaw": 1.0}, "O": {"round": 1.0}})
    obj.emotive_lipsync.viseme_set, obj.emotive_lipsync.viseme_set_file = "FILE", str(path)
    assert bpy.ops.emotive_lipsync.auto_map(mesh="Toon") == {"FINISHED"}
    mapping = obj.emotive_lipsync.mapping_dict()
    assert mapping["AI"] == {"wide_open": 1.0} and mapping["MBP"] == {"MBP": 1.0} and mapping["O"] == {"O": 1.0}
    assert import_module(MODULE + ".blender.run").mesh_viseme_set(obj).name == "studio_chart"


def test_mapping_rows_are_added_and_removed_by_hand(empty_scene):
    keys, _open = HEADS["vroid"]
    obj = build_head("Face", keys)
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.emotive_lipsync.mapping_add() == {"FINISHED"}
    assert len(obj.emotive_lipsync.mapping) == 1
    assert bpy.ops.emotive_lipsync.mapping_remove() == {"FINISHED"}
    assert len(obj.emotive_lipsync.mapping) == 0
    lamp = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", "POINT"))
    empty_scene.collection.objects.link(lamp)
    bpy.context.view_layer.objects.active = lamp
    with pytest.raises(RuntimeError, match="not a mesh"):
        bpy.ops.emotive_lipsync.mapping_add()
