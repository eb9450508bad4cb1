"""Gestures beside speech on real characters, driven by the operators: the
human sample head (ARKit keys, a lone head mesh whose object turns), a
Ready Player Me style avatar with Neck, Head and eye bones, a VRoid face.

The line is the sample's "hello" said five times with pauses between
(35 s), so that blink rates mean something; blinks are read off the keys
the way an animator sees them (the lids more than half closed), the eyes and
head off the bones and object Blender evaluates."""

from __future__ import annotations

import os
import wave
from importlib import import_module

import bpy
import numpy as np
import pytest
from mathutils import Quaternion, Vector

from conftest import MODULE, SAMPLE, fcurve_values
from heads import HEADS, build_head

import human

FPS = 30
FIRST = 1
HELLO = open(os.path.splitext(SAMPLE)[0] + ".txt", encoding="utf-8").read().strip()


@pytest.fixture(scope="module")
def take(tmp_path_factory):
    """(path, transcript) of the long take: hello.wav five times, 0.6-1.2 s apart."""
    with wave.open(SAMPLE) as w:
        params, frames = w.getparams(), w.readframes(w.getnframes())
    rate, width = params.framerate, params.sampwidth * params.nchannels
    out = tmp_path_factory.mktemp("take") / "five_hellos.wav"
    with wave.open(str(out), "wb") as w:
        w.setparams(params)
        for gap in (0.6, 1.2, 0.8, 1.0, 0.7):
            w.writeframes(frames + b"\0" * (int(gap * rate) * width))
    return str(out), " ".join([HELLO] * 5)


@pytest.fixture(scope="module")
def engine_result(take, extension):
    """What the engine finds on the take (the same as the operator's run, which is deterministic)."""
    pipeline = import_module(MODULE + ".engine.pipeline")
    settings = import_module(MODULE + ".engine.settings").LineSettings.of(fps=FPS)
    decode = import_module(MODULE + ".blender.sources").decode
    return pipeline.analyze(decode(take[0]), take[1], settings)


def generate(obj, take, **more):
    result = bpy.ops.emotive_lipsync.generate("EXEC_DEFAULT", True, filepath=take[0], frame=FIRST, mesh=obj.name,
                                              text=take[1], **more)
    assert result == {"FINISHED"}


def runs_above_half(values):
    """(start s, length s) of each stretch with ``values`` above 0.5, per frame."""
    closed = np.concatenate([[False], np.asarray(values) > 0.5, [False]])
    edges = np.flatnonzero(np.diff(closed.astype(int)))
    return [((a) / FPS, (b - a) / FPS) for a, b in zip(edges[::2], edges[1::2])]


def per_frame(obj_or_key, path, index, n):
    compat = import_module(MODULE + ".blender.compat")
    fc = compat.find_fcurve(obj_or_key, path, index)
    assert fc is not None, f"no F-curve {path}[{index}]"
    return np.array([fc.evaluate(FIRST + k) for k in range(n)])


def check_blinks(lids, result):
    """Human blinks on the per-frame lid values of a line."""
    minutes = result.duration / 60
    shut = runs_above_half(lids)
    assert 8 <= len(shut) / minutes <= 35, len(shut) / minutes
    assert all(0.05 <= length <= 0.5 for _, length in shut), shut
    pauses = import_module(MODULE + ".engine.gestures").pauses(result.alignment)
    starts = [s for s, _ in result.gestures.blinks]
    near = [any(a - 0.35 <= s <= b + 0.35 for a, b in pauses) for s in starts]
    assert np.mean(near) >= 0.5, (starts, pauses)


def speech_and_pauses(result, n):
    t = np.arange(n) / FPS
    speaking = np.zeros(n, dtype=bool)
    for w in result.alignment.words:
        speaking |= (t >= w.start) & (t < w.end)
    pause = np.zeros(n, dtype=bool)
    for a, b in import_module(MODULE + ".engine.gestures").pauses(result.alignment):
        if b - a >= 0.5:
            pause |= (t >= a) & (t < b)
    return speaking, pause


def check_head(angles_deg, result):
    """(frames, 3) head angles: moving in speech, calmer in pauses."""
    speaking, pause = speech_and_pauses(result, len(angles_deg))
    angle = np.linalg.norm(angles_deg, axis=1)
    assert 0.7 <= angle[speaking].std() <= 8 or 0.7 <= np.sqrt(np.mean(angle[speaking] ** 2)) <= 8
    speed = np.linalg.norm(np.diff(angles_deg, axis=0), axis=1) * FPS
    assert speed[speaking[1:]].mean() >= 1.3 * speed[pause[1:]].mean()


@pytest.fixture
def human_head(empty_scene, head_data):
    return human.build("Human", "arkit")


@pytest.fixture(scope="session")
def head_data():
    return human.head_data(human.assets())


def test_the_sample_head_blinks_looks_and_moves(human_head, take, engine_result):
    obj = human_head
    generate(obj, take)
    n = len(engine_result.times)
    key = obj.data.shape_keys
    left = per_frame(key, 'key_blocks["eyeBlinkLeft"].value', 0, n)
    right = per_frame(key, 'key_blocks["eyeBlinkRight"].value', 0, n)
    assert np.array_equal(left, right)                    # both eyes together
    check_blinks(left, engine_result)
    # The eyes look about, both the same way, never far.
    out_l = per_frame(key, 'key_blocks["eyeLookOutLeft"].value', 0, n)
    in_r = per_frame(key, 'key_blocks["eyeLookInRight"].value', 0, n)
    assert np.allclose(out_l, in_r) and 0 < out_l.max() <= 0.6
    # The head turns on the object's delta rotation, about the neck (the object's origin).
    rot = np.stack([per_frame(obj, "delta_rotation_euler", i, n) for i in range(3)], axis=1)
    assert tuple(obj.rotation_euler) == (0.0, 0.0, 0.0)   # the object's own rotation is the user's
    check_head(np.degrees(rot), engine_result)
    # Same line, same motion; the summary says what moved.
    before = left.copy()
    generate(obj, take)
    assert np.array_equal(per_frame(key, 'key_blocks["eyeBlinkLeft"].value', 0, n), before)
    generate(obj, take, no_gestures=True)
    assert per_frame(key, 'key_blocks["eyeBlinkLeft"].value', 0, n).max() == 0.0
    assert np.abs(per_frame(obj, "delta_rotation_euler", 0, n)).max() == 0.0


def test_the_users_blink_and_head_keys_are_kept_and_clear_and_undo(human_head, take, engine_result):
    obj = human_head
    kb = obj.data.shape_keys.key_blocks["eyeBlinkLeft"]
    kb.value = 0.3
    kb.keyframe_insert("value", frame=40)
    obj.delta_rotation_euler = (0.1, 0.0, 0.0)
    obj.keyframe_insert("delta_rotation_euler", frame=40)
    generate(obj, take)
    frames, values = fcurve_values(obj, "eyeBlinkLeft")
    assert list(frames) == [40.0] and list(values) == pytest.approx([0.3])   # nothing added
    assert fcurve_values(obj, "eyeBlinkRight") is not None                   # the other eye still blinks
    compat = import_module(MODULE + ".blender.compat")
    assert len(compat.find_fcurve(obj, "delta_rotation_euler", 0).keyframe_points) == 1
    # Clear takes the gestures with the rest and leaves the user's keys; undo brings the gestures back.
    bpy.ops.ed.undo_push(message="before clear")
    assert bpy.ops.emotive_lipsync.clear("EXEC_DEFAULT", True, mesh=obj.name) == {"FINISHED"}
    obj = bpy.data.objects["Human"]
    frames, values = fcurve_values(obj, "eyeBlinkLeft")
    assert list(frames) == [40.0]
    assert fcurve_values(obj, "eyeBlinkRight") is None
    assert len(compat.find_fcurve(obj, "delta_rotation_euler", 0).keyframe_points) == 1
    bpy.ops.ed.undo()
    obj = bpy.data.objects["Human"]
    assert fcurve_values(obj, "eyeBlinkRight") is not None


def _avatar(euler_head=False):
    """A Ready Player Me style avatar: an armature (Hips, Spine, Neck, Head,
    LeftEye, RightEye; Y up along each bone, the character facing -Y) and a
    head mesh with RPM's shape keys, deformed by it."""
    arm_data = bpy.data.armatures.new("Armature")
    arm = bpy.data.objects.new("Armature", arm_data)
    bpy.context.scene.collection.objects.link(arm)
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode="EDIT")
    bones = {}
    for name, head, tail, parent in (("Hips", (0, 0, 0.9), (0, 0, 1.1), None),
                                     ("Spine", (0, 0, 1.1), (0, 0, 1.45), "Hips"),
                                     ("Neck", (0, 0, 1.45), (0, 0, 1.55), "Spine"),
                                     ("Head", (0, 0, 1.55), (0, 0, 1.75), "Neck"),
                                     ("LeftEye", (0.03, -0.08, 1.65), (0.03, -0.1, 1.65), "Head"),
                                     ("RightEye", (-0.03, -0.08, 1.65), (-0.03, -0.1, 1.65), "Head")):
        b = arm_data.edit_bones.new(name)
        b.head, b.tail = head, tail
        if parent:
            b.parent = bones[parent]
        bones[name] = b
    bpy.ops.object.mode_set(mode="OBJECT")
    if euler_head:
        arm.pose.bones["Head"].rotation_mode = "XYZ"
    keys, _ = HEADS["ready_player_me"]
    face = build_head("Wolf3D_Head", keys)
    face.parent = arm
    mod = face.modifiers.new("Armature", "ARMATURE")
    mod.object = arm
    return arm, face


def _bone_world(arm, name, frame):
    bpy.context.scene.frame_set(frame)
    return arm.matrix_world @ arm.pose.bones[name].matrix


@pytest.mark.parametrize("euler_head", [False, True], ids=["quaternion", "euler"])
def test_a_bone_avatar_turns_its_head_neck_and_eyes(empty_scene, take, engine_result, euler_head):
    arm, face = _avatar(euler_head)
    generate(face, take)
    n = len(engine_result.times)
    compat = import_module(MODULE + ".blender.compat")
    paths = {fc.data_path for fc in compat.fcurves_of(arm)}
    mode = "rotation_euler" if euler_head else "rotation_quaternion"
    assert {f'pose.bones["Head"].{mode}', 'pose.bones["Neck"].rotation_quaternion',
            'pose.bones["LeftEye"].rotation_quaternion', 'pose.bones["RightEye"].rotation_quaternion'} <= paths
    rest = {b: (arm.matrix_world @ arm.data.bones[b].matrix_local) for b in ("Head", "LeftEye", "RightEye")}
    angles, eye_angles = [], []
    for k in range(0, n, 2):
        m = _bone_world(arm, "Head", FIRST + k)
        # The head's turn from rest, as (pitch down, yaw left, roll) from its axes in the world.
        q = (rest["Head"].to_3x3().inverted() @ m.to_3x3()).to_quaternion()
        fwd = m.to_3x3() @ rest["Head"].to_3x3().inverted() @ Vector((0, -1, 0))
        up = m.to_3x3() @ rest["Head"].to_3x3().inverted() @ Vector((0, 0, 1))
        angles.append((np.degrees(np.arcsin(-fwd.z)), np.degrees(np.arctan2(fwd.x, -fwd.y)),
                       np.degrees(np.arcsin(up.x))))
        assert q.angle < np.radians(20)
        dirs = []
        for eye in ("LeftEye", "RightEye"):
            e = _bone_world(arm, eye, FIRST + k)
            axis = e.to_3x3() @ Vector((0, 1, 0))            # the bone's Y: where the eye looks
            at_rest = rest[eye].to_3x3() @ Vector((0, 1, 0))
            head_turn = m.to_3x3() @ rest["Head"].to_3x3().inverted()
            dirs.append(axis)
            eye_angles.append(np.degrees((head_turn @ at_rest).angle(axis)))
        assert dirs[0].angle(dirs[1]) < np.radians(0.5)      # both eyes point the same way
    assert max(eye_angles) <= 20 and max(eye_angles) > 1
    angles = np.array(angles)
    full = np.stack([np.interp(np.arange(n), np.arange(0, n, 2), angles[:, j]) for j in range(3)], axis=1)
    check_head(full, engine_result)
    # Clear on the face takes the bones' keys too; the user's bone keys elsewhere would stay.
    assert bpy.ops.emotive_lipsync.clear(mesh=face.name) == {"FINISHED"}
    assert not any(fc.data_path.startswith('pose.bones["Head"]') and len(fc.keyframe_points)
                   for fc in compat.fcurves_of(arm))


def test_a_head_bone_the_user_animated_is_left_alone(empty_scene, take):
    arm, face = _avatar()
    pb = arm.pose.bones["Head"]
    pb.rotation_quaternion = (0.99, 0.1, 0.0, 0.0)
    pb.keyframe_insert("rotation_quaternion", frame=12)
    generate(face, take)
    compat = import_module(MODULE + ".blender.compat")
    fc = compat.find_fcurve(arm, 'pose.bones["Head"].rotation_quaternion', 0)
    assert [k.co[0] for k in fc.keyframe_points] == [12.0]
    assert len(compat.find_fcurve(arm, 'pose.bones["Neck"].rotation_quaternion', 0).keyframe_points) > 10
    assert bpy.ops.emotive_lipsync.clear(mesh=face.name) == {"FINISHED"}
    fc = compat.find_fcurve(arm, 'pose.bones["Head"].rotation_quaternion', 0)
    assert [k.co[0] for k in fc.keyframe_points] == [12.0]


def test_a_vroid_face_blinks_on_its_own_keys(empty_scene, take, engine_result):
    keys, _ = HEADS["vroid"]
    obj = build_head("Face", {**keys, "Fcl_EYE_Close_L": {}, "Fcl_EYE_Close_R": {}})
    generate(obj, take)
    n = len(engine_result.times)
    lids = per_frame(obj.data.shape_keys, 'key_blocks["Fcl_EYE_Close_L"].value', 0, n)
    assert np.array_equal(lids, per_frame(obj.data.shape_keys, 'key_blocks["Fcl_EYE_Close_R"].value', 0, n))
    check_blinks(lids, engine_result)
    assert fcurve_values(obj, "Fcl_EYE_Close") is None        # the eyes' own keys, not the one closing both


def test_the_command_line_turns_gestures_off(empty_scene, take):
    arm, face = _avatar()
    command = import_module(MODULE + ".blender.command")
    assert command.execute(["--audio", take[0], "--mesh", face.name, "--text", take[1], "--no-gestures"]) == 0
    compat = import_module(MODULE + ".blender.compat")
    assert not [fc for fc in compat.fcurves_of(arm) if fc.data_path.startswith("pose.bones")]
    assert fcurve_values(face, "eyeBlinkLeft") is None
    assert command.execute(["--audio", take[0], "--mesh", face.name, "--text", take[1], "--gesture-seed", "2"]) == 0
    assert fcurve_values(face, "eyeBlinkLeft") is not None


def test_auto_map_says_which_gestures_the_face_can_show(empty_scene, capsys):
    _arm, face = _avatar()
    assert bpy.ops.emotive_lipsync.auto_map(mesh=face.name) == {"FINISHED"}
    said = capsys.readouterr().out
    assert "Blinks: eyeBlinkLeft, eyeBlinkRight; Gaze: LeftEye, RightEye, 8 look keys" in said, said
    assert "Head: Neck, Head" in said and "no " not in said.split("gestures:")[1], said
    keys, _ = HEADS["oculus"]
    build_head("Plain", keys)
    assert bpy.ops.emotive_lipsync.auto_map(mesh="Plain") == {"FINISHED"}
    said = capsys.readouterr().out
    assert "no blinks" in said and "no gaze" in said and "no head" not in said, said   # the object turns


def test_the_gltf_export_carries_the_head_eyes_and_blinks(empty_scene, take, tmp_path):
    """A game pipeline's route: the avatar exported to glTF carries the head,
    neck and eye bones' rotations and the blinks as morph-target weights."""
    from test_gltf import GLTF_EXPORT, _accessor, _call, _enable, _morph_animation, _read_gltf

    arm, face = _avatar()
    group = face.vertex_groups.new(name="Head")
    group.add(list(range(len(face.data.vertices))), 1.0, "REPLACE")
    generate(face, take)
    _enable("io_scene_gltf2")
    out = str(tmp_path / "avatar.gltf")
    _call(bpy.ops.export_scene.gltf, filepath=out, **GLTF_EXPORT)
    doc, buffers = _read_gltf(out)
    node = {n.get("name"): i for i, n in enumerate(doc["nodes"])}
    rotations = {}
    for anim in doc.get("animations", []):
        for ch in anim["channels"]:
            target = ch["target"]
            if target["path"] == "rotation" and target.get("node") in (node["Head"], node["Neck"],
                                                                        node["LeftEye"], node["RightEye"]):
                sampler = anim["samplers"][ch["sampler"]]
                rotations[doc["nodes"][target["node"]]["name"]] = _accessor(doc, buffers, sampler["output"])
    assert set(rotations) == {"Head", "Neck", "LeftEye", "RightEye"}
    for name, q in rotations.items():
        turn = np.degrees(2 * np.arccos(np.clip(np.abs(q @ q[0]), 0, 1)))   # from the first sample
        assert 0.5 < turn.max() < 25, (name, turn.max())
    np.testing.assert_allclose(rotations["LeftEye"], rotations["RightEye"], atol=1e-5)
    names, _times, weights, _interp = _morph_animation(doc, buffers, face.name)
    left, right = weights[:, names.index("eyeBlinkLeft")], weights[:, names.index("eyeBlinkRight")]
    assert left.max() > 0.9 and np.allclose(left, right, atol=1e-4)


def test_the_panel_lists_the_channels_found_and_the_ones_missing(human_head):
    from types import SimpleNamespace

    from test_edits import _Layout

    panel = import_module(MODULE + ".blender.gestures_ui").LIPSYNC_PT_gestures
    st = bpy.context.scene.emotive_lipsync
    st.target = human_head
    layout = _Layout()
    panel.draw_header(SimpleNamespace(layout=layout), bpy.context)
    panel.draw(SimpleNamespace(layout=layout), bpy.context)
    assert layout.props == ["gestures", "gesture_seed"]
    assert layout.labels == ["Blinks: eyeBlinkLeft, eyeBlinkRight", "Gaze: 8 look keys (eyeLookDownLeft ...)",
                             "Head: the object's delta rotation"]
    assert not [t for t in layout.labels if t.startswith("No ")]
    keys, _ = HEADS["oculus"]
    st.target = build_head("Plain", keys)
    layout = _Layout()
    panel.draw(SimpleNamespace(layout=layout), bpy.context)
    assert "No blinks (no eyeBlink or Fcl_EYE_Close keys)" in layout.labels
    assert "No gaze (no eyeLook keys or eye bones)" in layout.labels


def test_a_pose_the_user_set_is_kept_under_the_motion_and_put_back_by_clear(empty_scene, take, engine_result):
    """A head the animator tilted (a pose, no keys) moves about that tilt,
    on every Generate alike, and Clear leaves it tilted as it was."""
    arm, face = _avatar()
    tilt = Quaternion((1.0, 0.0, 0.12, 0.0)).normalized()      # about 14 degrees
    arm.pose.bones["Head"].rotation_quaternion = tilt
    n = len(engine_result.times)
    path = 'pose.bones["Head"].rotation_quaternion'
    for _run in range(2):
        generate(face, take)
        q = np.stack([per_frame(arm, path, i, n) for i in range(4)], axis=1)
        off = np.degrees(2 * np.arccos(np.clip(np.abs(q @ np.array(tilt)), 0, 1)))
        assert off.max() < 12 and np.median(off) < 4, (off.max(), np.median(off))   # about the tilt, not rest
    assert bpy.ops.emotive_lipsync.clear(mesh=face.name) == {"FINISHED"}
    back = arm.pose.bones["Head"].rotation_quaternion
    assert Quaternion(back).rotation_difference(tilt).angle < 1e-4


def test_a_studios_gestures_file_names_its_channels_and_a_bad_one_is_refused(empty_scene, take, tmp_path, monkeypatch):
    userdata = import_module(MODULE + ".blender.userdata")
    monkeypatch.setattr(userdata, "conventions_folder", lambda: str(tmp_path))
    keys, _ = HEADS["oculus"]
    obj = build_head("Studio", {**keys, "Lid_Close_L": {}, "Lid_Close_R": {}})
    (tmp_path / "gestures.json").write_text('{"shape_keys": {"blink_L": ["Lid_Close_L"], "blink_R": ["Lid_Close_R"]}}')
    generate(obj, take)
    assert fcurve_values(obj, "Lid_Close_L")[1].max() > 0.9
    # A malformed file: Generate is refused with the file and field named, nothing changes.
    before = fcurve_values(obj, "Lid_Close_L")
    (tmp_path / "gestures.json").write_text('{"shape_keys": {"blink_L": "Lid_Close_L"}}')
    with pytest.raises(RuntimeError, match=r"gestures\.json.*shape_keys\.blink_L.*list of names"):
        bpy.ops.emotive_lipsync.generate(filepath=take[0], frame=FIRST + 100, mesh=obj.name, text=take[1])
    after = fcurve_values(obj, "Lid_Close_L")
    assert np.array_equal(before[0], after[0]) and np.array_equal(before[1], after[1])


def test_an_armature_linked_from_a_library_is_not_touched(empty_scene, take, tmp_path):
    """The face is local, its armature linked from another file: the face
    blinks, the bones are left as they are and the report says why."""
    arm, face = _avatar()
    lib = str(tmp_path / "rig.blend")
    bpy.data.libraries.write(lib, {arm})
    face.parent = None
    for mod in face.modifiers:
        face.modifiers.remove(mod)
    bpy.data.objects.remove(arm)
    with bpy.data.libraries.load(lib, link=True) as (src, dst):
        dst.objects = ["Armature"]
    linked = dst.objects[0]
    bpy.context.scene.collection.objects.link(linked)
    mod = face.modifiers.new("Armature", "ARMATURE")
    mod.object = linked
    generate(face, take)
    assert fcurve_values(face, "eyeBlinkLeft") is not None
    assert linked.animation_data is None
    said = import_module(MODULE + ".blender.gestures").describe(face)[1]
    assert any("is linked from a library" in s for s in said), said
