"""Bad input through the operators: each case raises a ``RuntimeError``
with a clear message (no traceback) and leaves the user's keys and shape
keys as they were, or works and says what it had to guess."""

from __future__ import annotations

import os
import shutil
from importlib import import_module

import bpy
import pytest

from conftest import FIXTURES, MODULE, keyed_shape_keys

BOB = os.path.join(FIXTURES, "bob_map.wav")


def _generate(**kw):
    return bpy.ops.emotive_lipsync.generate("EXEC_DEFAULT", **kw)


def _snapshot(obj):
    """Everything of ``obj``'s shape keys a failed operator must not change."""
    key = obj.data.shape_keys
    if key is None:
        return None
    curves = []
    compat = import_module(MODULE + ".blender.compat")
    for fc in compat.fcurves(key):
        curves.append((fc.data_path, tuple(tuple(k.co) for k in fc.keyframe_points)))
    return ([(kb.name, kb.value) for kb in key.key_blocks], sorted(curves))


def _refused(match, obj, **kw):
    """The operator raises a RuntimeError matching ``match``, without a
    traceback in its message, and ``obj``'s shape keys are unchanged."""
    before = _snapshot(obj)
    with pytest.raises(RuntimeError, match=match) as exc:
        _generate(**kw)
    assert "Traceback" not in str(exc.value)
    assert _snapshot(obj) == before
    return str(exc.value)


# --- transcripts -------------------------------------------------------------------

def test_latin1_sidecar_transcript_is_read(scene, tmp_path, capsys):
    shutil.copy(BOB, tmp_path / "line.wav")
    (tmp_path / "line.txt").write_bytes("Bob bought a map, café.".encode("latin-1"))
    assert _generate(mesh="Ada", filepath=str(tmp_path / "line.wav"), frame=1) == {"FINISHED"}
    assert "MBP" in keyed_shape_keys(bpy.data.objects["Ada"])
    assert "not UTF-8" in capsys.readouterr().out


def test_binary_sidecar_transcript_is_named(scene, tmp_path):
    shutil.copy(BOB, tmp_path / "line.wav")
    (tmp_path / "line.txt").write_bytes(b"\x00\x01\x02garbage\x00")
    msg = _refused("not a text file", bpy.data.objects["Ada"], mesh="Ada",
                   filepath=str(tmp_path / "line.wav"), frame=1)
    assert str(tmp_path / "line.txt") in msg


def test_load_transcript_reads_utf16_and_cp1252(scene, tmp_path):
    (tmp_path / "a.txt").write_bytes("Bob bought a map, café.".encode("utf-16"))
    (tmp_path / "b.txt").write_bytes("Bob bought a map, café \u2019.".encode("cp1252"))
    assert bpy.ops.emotive_lipsync.load_transcript(filepath=str(tmp_path / "a.txt")) == {"FINISHED"}
    assert scene.emotive_lipsync.text_block.as_string() == "Bob bought a map, café."
    assert bpy.ops.emotive_lipsync.load_transcript(filepath=str(tmp_path / "b.txt")) == {"FINISHED"}
    assert scene.emotive_lipsync.text_block.as_string() == "Bob bought a map, café \u2019."
    (tmp_path / "c.txt").write_bytes(b"\x00\x00")
    with pytest.raises(RuntimeError, match="not a text file"):
        bpy.ops.emotive_lipsync.load_transcript(filepath=str(tmp_path / "c.txt"))


def test_skipped_words_are_reported(scene, tmp_path, capsys):
    """The batch command prints the operator's summary: it names the words left out."""
    shutil.copy(BOB, tmp_path / "line.wav")
    command = import_module(MODULE + ".blender.command")
    assert command.execute(["--audio", str(tmp_path / "line.wav"), "--mesh", "Ada",
                            "--text", "Bob 😀 bought 你好 a map."]) == 0
    out = capsys.readouterr().out
    assert "warning: 2 words of the transcript left out" in out and "'你好' (not in the Latin alphabet: CJK)" in out
    assert "MBP" in keyed_shape_keys(bpy.data.objects["Ada"])


# --- audio and arguments -----------------------------------------------------------

def test_audio_folder_and_bad_start_frame(scene, tmp_path):
    ada = bpy.data.objects["Ada"]
    assert _generate(mesh="Ada", filepath=BOB, frame=1, text="Bob bought a map.") == {"FINISHED"}
    (tmp_path / "take.wav").mkdir()
    _refused("audio path is a folder, not a file: " + str(tmp_path / "take.wav"), ada, mesh="Ada",
             filepath=str(tmp_path / "take.wav"), frame=1, text="Bob")
    _refused("start frame -5 is not allowed", ada, mesh="Ada", filepath=BOB, frame=-5, text="Bob")
    _refused("audio file not found", ada, mesh="Ada", filepath=str(tmp_path / "nope.wav"), frame=1, text="Bob")
    (tmp_path / "junk.wav").write_text("not audio")
    msg = _refused("junk.wav", ada, mesh="Ada", filepath=str(tmp_path / "junk.wav"), frame=1, text="Bob")
    assert ".." not in msg


def test_too_short_and_silent_audio(scene, tmp_path):
    import wave

    import numpy as np

    ada = bpy.data.objects["Ada"]
    for name, seconds, level in (("short.wav", 0.05, 0.3), ("silent.wav", 1.0, 0.0)):
        t = np.arange(int(seconds * 16000)) / 16000
        with wave.open(str(tmp_path / name), "wb") as w:
            w.setnchannels(1), w.setsampwidth(2), w.setframerate(16000)
            w.writeframes((level * np.sin(2 * np.pi * 200 * t) * 32767).astype("<i2").tobytes())
    _refused("too short to hold speech", ada, mesh="Ada", filepath=str(tmp_path / "short.wav"), frame=1, text="Bob")
    _refused("holds no speech", ada, mesh="Ada", filepath=str(tmp_path / "silent.wav"), frame=1, text="Bob")


# --- linked (library) meshes -----------------------------------------------------------

def _link_ada(scene, tmp_path, keyed=True):
    """Ada (lip-synced once if ``keyed``) written to a library .blend and linked into a new file."""
    if keyed:
        assert _generate(mesh="Ada", filepath=BOB, frame=1, text="Bob bought a map.") == {"FINISHED"}
    lib = str(tmp_path / "characters.blend")
    bpy.data.libraries.write(lib, {bpy.data.objects["Ada"]}, fake_user=True)
    bpy.ops.wm.read_homefile(use_empty=True)
    with bpy.data.libraries.load(lib, link=True) as (_src, dst):
        dst.objects = ["Ada"]
    ada = dst.objects[0]
    bpy.context.scene.collection.objects.link(ada)
    bpy.context.scene.render.fps, bpy.context.scene.render.fps_base = 30, 1.0
    return ada


def test_linked_mesh_is_refused_and_unchanged(scene, tmp_path):
    ada = _link_ada(scene, tmp_path)
    assert ada.library is not None and ada.data.shape_keys.library is not None
    keyed = keyed_shape_keys(ada)
    assert "MBP" in keyed
    msg = _refused("linked from the library", ada, mesh="Ada", filepath=BOB, frame=40, text="Bob bought a map.")
    assert "characters.blend" in msg and "Nothing was changed" in msg
    with pytest.raises(RuntimeError, match="linked from the library"):
        bpy.ops.emotive_lipsync.clear(mesh="Ada")
    assert keyed_shape_keys(ada) == keyed


def test_override_of_the_object_alone_is_refused(scene, tmp_path):
    ada = _link_ada(scene, tmp_path)
    over = ada.override_create(remap_local_usages=True)
    assert over.library is None and over.data.library is not None
    _refused("mesh data 'Ada' is linked", over, mesh=over.name, filepath=BOB, frame=1, text="Bob bought a map.")


def test_editable_override_of_object_and_mesh_works(scene, tmp_path):
    ada = _link_ada(scene, tmp_path, keyed=False)
    over = ada.override_create(remap_local_usages=True)
    over.data.override_create(remap_local_usages=True)
    assert over.data.library is None and over.data.shape_keys.library is None
    assert _generate(mesh=over.name, filepath=BOB, frame=1, text="Bob bought a map.") == {"FINISHED"}
    assert "MBP" in keyed_shape_keys(over)
    assert bpy.ops.emotive_lipsync.clear(mesh=over.name) == {"FINISHED"}
    assert keyed_shape_keys(over) == set()


def test_override_keeps_a_linked_action_and_says_so(scene, tmp_path):
    """The library's own lip sync stays in its (linked) action: a clear error, not a silent copy."""
    ada = _link_ada(scene, tmp_path)
    over = ada.override_create(remap_local_usages=True)
    over.data.override_create(remap_local_usages=True)
    _refused("action 'Ada_LipSync' is linked", over, mesh=over.name, filepath=BOB, frame=1, text="Bob")


def test_linked_action_on_a_local_mesh_is_refused(scene, tmp_path):
    ada = bpy.data.objects["Ada"]
    assert _generate(mesh="Ada", filepath=BOB, frame=1, text="Bob bought a map.") == {"FINISHED"}
    action = ada.data.shape_keys.animation_data.action
    action.name = "AdaTalk"
    lib = str(tmp_path / "actions.blend")
    bpy.data.libraries.write(lib, {action}, fake_user=True)
    with bpy.data.libraries.load(lib, link=True) as (_src, dst):
        dst.actions = ["AdaTalk"]
    linked = dst.actions[0]
    assert linked.library is not None
    ada.data.shape_keys.animation_data.action = linked
    assert ada.data.shape_keys.animation_data.action == linked
    _refused("action 'AdaTalk' is linked", ada, mesh="Ada", filepath=BOB, frame=1, text="Bob bought a map.")


# --- meshes ------------------------------------------------------------------------------

def test_no_mesh_basis_only_and_non_mesh(scene):
    ada = bpy.data.objects["Ada"]
    assert _generate(mesh="Ada", filepath=BOB, frame=1, text="Bob bought a map.") == {"FINISHED"}
    before = _snapshot(ada)
    bpy.ops.mesh.primitive_cube_add()
    cube = bpy.context.active_object
    with pytest.raises(RuntimeError, match="has no shape keys to animate"):
        _generate(mesh=cube.name, filepath=BOB, frame=1, text="Bob")
    cube.shape_key_add(name="Basis")
    with pytest.raises(RuntimeError, match="has no shape keys to animate"):
        _generate(mesh=cube.name, filepath=BOB, frame=1, text="Bob")
    assert cube.data.shape_keys.animation_data is None and len(cube.data.shape_keys.key_blocks) == 1
    cam = bpy.data.objects["Camera"]
    with pytest.raises(RuntimeError, match="'Camera' is a camera, not a mesh"):
        _generate(mesh="Camera", filepath=BOB, frame=1, text="Bob")
    with pytest.raises(RuntimeError, match="no object named 'Nobody'"):
        _generate(mesh="Nobody", filepath=BOB, frame=1, text="Bob")
    bpy.context.view_layer.objects.active = None
    scene.emotive_lipsync.target = None
    with pytest.raises(RuntimeError, match="no face mesh"):
        _generate(filepath=BOB, frame=1, text="Bob")
    with pytest.raises(RuntimeError, match="is a camera, not a mesh"):
        bpy.ops.emotive_lipsync.clear(mesh="Camera")
    assert cam.animation_data is None
    assert _snapshot(ada) == before


def test_clear_on_a_mesh_never_lip_synced_changes_nothing(scene):
    kit = bpy.data.objects["Kit"]
    before = _snapshot(kit)
    assert bpy.ops.emotive_lipsync.clear(mesh="Kit") == {"CANCELLED"}
    assert _snapshot(kit) == before


def test_transcript_of_other_scripts_and_punctuation(scene):
    ada = bpy.data.objects["Ada"]
    _refused("no words the aligner can use: 'Привет'", ada, mesh="Ada", filepath=BOB, frame=1, text="Привет мир")
    _refused("no spoken words", ada, mesh="Ada", filepath=BOB, frame=1, text="... ?! --")
    assert keyed_shape_keys(ada) == set()
