"""The gestures beside speech on a character: blinks and gaze on its shape
keys (keyed with the speech, see :mod:`.run`), the head, neck and eyes on
its bones, or, for a head mesh with no armature, the head on the object's
delta rotation (which leaves the object's own rotation to the user).

The engine gives every turn as quaternions in the character's frame
(:func:`..engine.gestures.bone_turns`); here they become each bone's own
rotation, composed with the pose the bone holds, in the bone's rotation
mode.  What this writes is recorded under :data:`RECORD` on the armature or
object, apart from any lip sync of the armature itself, so *Clear* removes
it and nothing else.  A bone or object the user animates (keys or a driver
on its rotation that lip sync did not write) is left alone.
"""

from __future__ import annotations

import json
from pathlib import Path

import bpy
import numpy as np
from mathutils import Quaternion

from ..engine import conventions, gestures, keys
from ..engine.datafile import read_object
from . import compat, keying, userdata

RECORD = "emotive_lipsync_gestures"
#: The pose each bone (and a lone head's delta rotation) held before the
#: gestures first keyed it: later runs key on top of it, Clear puts it back.
HELD = "emotive_lipsync_gestures_pose"
#: What a lone head mesh turns by.
OBJECT_TURN = "delta_rotation_euler"


_read: dict = {}   # path -> ((modification time, size), its checked table)


def _extra() -> dict | None:
    """A studio's own channel names: gestures.json in the user's conventions
    folder, read again only when it changes (the panel asks on every redraw);
    a malformed file is a :class:`..engine.errors.PresetError` naming it."""
    folder = userdata.conventions_folder()
    path = Path(folder) / conventions.GESTURES_FILE if folder else None
    if path is None or not path.is_file():
        return None
    stat = path.stat()
    stamp = (stat.st_mtime_ns, stat.st_size)
    if _read.get(str(path), (None,))[0] != stamp:
        _read[str(path)] = (stamp, gestures.check_table(read_object(path), str(path)))
    return _read[str(path)][1]


def armature_of(obj):
    """The armature that moves a mesh (its Armature modifier's, else its
    parent if that is an armature); an armature is its own."""
    if obj.type == "ARMATURE":
        return obj
    for mod in obj.modifiers:
        if mod.type == "ARMATURE" and mod.object is not None:
            return mod.object
    return obj.parent if obj.parent is not None and obj.parent.type == "ARMATURE" else None


def lone_head(obj) -> bool:
    """A head mesh with no armature and no parent: its object turns as the head."""
    return obj.type == "MESH" and armature_of(obj) is None and obj.parent is None


def channels(obj) -> gestures.Channels:
    """The gesture channels of ``obj``: its shape keys, its armature's bones."""
    key = obj.data.shape_keys if obj.type == "MESH" else None
    names = [kb.name for kb in key.key_blocks[1:]] if key is not None else []
    arm = armature_of(obj)
    if arm is not None and arm.library is not None:
        found = gestures.match(names, [], _extra())
        found.bones_locked = (f"head and eye bones ({arm.name!r} is linked from a library: make a library override "
                              "of it to animate them)")
        return found
    bones = [b.name for b in arm.data.bones] if arm is not None else []
    return gestures.match(names, bones, _extra())


def describe(obj) -> tuple[list[str], list[str]]:
    """What the panel and Auto-Map list: the channels found, a line per
    part (``Blinks: eyeBlinkLeft, eyeBlinkRight``), and what is missing, in words."""
    found = channels(obj)
    keys, bones = found.shape_keys, found.bones
    have = []
    blinks = sorted({k for r, k in keys.items() if r.startswith("blink")})
    if blinks:
        have.append("Blinks: " + ", ".join(blinks))
    looks = sorted({k for r, k in keys.items() if r.startswith("look")})
    gaze = [bones[r] for r in ("eye_L", "eye_R") if r in bones] + \
        (looks if len(looks) <= 2 else [f"{len(looks)} look keys ({looks[0]} ...)"])
    if gaze:
        have.append("Gaze: " + ", ".join(gaze))
    head = [bones[r] for r in ("neck", "head") if r in bones]
    if head or lone_head(obj):
        have.append("Head: " + (", ".join(head) if head else "the object's delta rotation"))
    return have, found.missing(lone_head(obj))


def _bone_path(name: str) -> str:
    return f'pose.bones["{bpy.utils.escape_identifier(name)}"]'


def _rotation_paths(name: str) -> tuple[str, ...]:
    return tuple(f"{_bone_path(name)}.{r}" for r in ("rotation_quaternion", "rotation_euler", "rotation_axis_angle"))


def _user_keys(id_data, paths: tuple[str, ...]) -> bool:
    """Keys or a driver on any of ``paths`` that lip sync's gestures did not write."""
    ad = id_data.animation_data
    if ad is not None and any(d.data_path in paths for d in ad.drivers):
        return True
    ours = keying.recorded_ranges(id_data, RECORD)
    for fc in compat.fcurves_of(id_data):
        if fc.data_path not in paths or not len(fc.keyframe_points):
            continue
        frames = keying.key_frames(fc)
        inside = np.zeros(len(frames), dtype=bool)
        for a, b in ours.get(f"{fc.array_index}:{fc.data_path}", []):
            inside |= (frames >= a - 1e-4) & (frames <= b + 1e-4)
        if not inside.all():
            return True
    return False


def animated(obj, found: gestures.Channels) -> list[str]:
    """The bones of ``found`` the user animates (and ``OBJECT_TURN`` for a
    lone head the user turns)."""
    arm = armature_of(obj)
    out = [b for b in found.bones.values() if arm is not None and _user_keys(arm, _rotation_paths(b))]
    if lone_head(obj) and _user_keys(obj, (OBJECT_TURN, "rotation_euler", "rotation_quaternion")):
        out.append(OBJECT_TURN)
    return out


def _in_world(arm, bone) -> np.ndarray:
    """The bone's rest axes in the world (columns), rotation only."""
    m = (arm.matrix_world.to_3x3() @ bone.matrix_local.to_3x3()).normalized()
    return np.array(m)


def _as_mode(q: np.ndarray, mode: str, hold) -> tuple[str, np.ndarray]:
    """Quaternions ``q`` (frames, 4) composed with the pose ``hold`` (a
    Quaternion) as the rotation channels of ``mode``: (data path suffix,
    (frames, k) values)."""
    out = [hold @ Quaternion(row) for row in q]
    if mode == "QUATERNION":
        return "rotation_quaternion", np.array([tuple(x) for x in out])
    if mode == "AXIS_ANGLE":
        return "rotation_axis_angle", np.array([(x.angle, *x.axis) for x in out])
    prev = None
    eul = []
    for x in out:
        e = x.to_euler(mode, prev) if prev is not None else x.to_euler(mode)
        eul.append(tuple(e))
        prev = e
    return "rotation_euler", np.array(eul)


def write(obj, line: keys.LineKeys, motion, first_frame: int, tolerance: float, label: str) -> list[str]:
    """Key the turns of ``line`` (bones) on ``obj``'s armature, or the head
    of ``motion`` on a lone head's delta rotation; the names keyed."""
    arm = armature_of(obj)
    written = []
    last = first_frame + len(line.times) - 1
    forget(obj, first_frame, last, keep=set(line.turns) | ({OBJECT_TURN} if motion is not None else set()))
    if arm is not None and line.turns:
        paths, columns = [], []
        for name, q in line.turns.items():
            pb = arm.pose.bones.get(name)
            if pb is None:
                continue
            local = gestures.in_bone_frame(q, _in_world(arm, pb.bone))
            hold = _pose_rotation(pb, arm)
            suffix, values = _as_mode(local, pb.rotation_mode, hold)
            base = f"{_bone_path(name)}.{suffix}"
            for i in range(values.shape[1]):
                paths.append((base, i))
                columns.append(values[:, i])
            written.append(name)
        if paths:
            keying.write_owned(arm, RECORD, paths, np.stack(columns, axis=1), first_frame, tolerance, label,
                               owner=obj.name)
    elif motion is not None and lone_head(obj) and f"{obj.name}'s rotation" not in line.gesture_kept:
        q = gestures.character_turns(*motion.head.T)
        local = gestures.in_bone_frame(q, np.array(obj.matrix_world.to_3x3().normalized()))
        hold = _held(obj)
        eul = []
        prev = None
        for row in local:
            e = Quaternion(row).to_euler("XYZ", prev) if prev is not None else Quaternion(row).to_euler("XYZ")
            eul.append((e.x + hold[0], e.y + hold[1], e.z + hold[2]))
            prev = e
        values = np.array(eul)
        keying.write_owned(obj, RECORD, [(OBJECT_TURN, i) for i in range(3)], values, first_frame, tolerance,
                           label, owner=obj.name)
        written.append("head (object)")
    return written


def _held_map(holder) -> dict:
    try:
        return json.loads(holder.get(HELD, "{}"))
    except (TypeError, ValueError):
        return {}


def _remember(holder, name: str, value) -> None:
    held = _held_map(holder)
    held[name] = [float(x) for x in value]
    holder[HELD] = json.dumps(held)


def _held(obj) -> tuple[float, ...]:
    """The delta rotation a lone head held before the gestures first keyed
    it (its value now, the first time)."""
    held = _held_map(obj)
    if OBJECT_TURN not in held:
        _remember(obj, OBJECT_TURN, getattr(obj, OBJECT_TURN))
        held = _held_map(obj)
    return tuple(held[OBJECT_TURN])


def _rotation_now(pb) -> Quaternion:
    if pb.rotation_mode == "QUATERNION":
        return pb.rotation_quaternion.copy()
    if pb.rotation_mode == "AXIS_ANGLE":
        a = pb.rotation_axis_angle
        return Quaternion((a[1], a[2], a[3]), a[0])
    return pb.rotation_euler.to_quaternion()


def _pose_rotation(pb, arm) -> Quaternion:
    """The pose a bone held before the gestures first keyed it (its
    rotation now, the first time)."""
    held = _held_map(arm)
    if pb.name not in held:
        _remember(arm, pb.name, _rotation_now(pb))
        held = _held_map(arm)
    return Quaternion(held[pb.name])


def _restore(holder, forget_them: bool = True) -> None:
    """Put back the poses the gestures keyed on top of (Clear, a run with
    the gestures off); ``forget_them``: and forget them."""
    for name, value in _held_map(holder).items():
        if name == OBJECT_TURN:
            setattr(holder, OBJECT_TURN, value)
            continue
        pb = holder.pose.bones.get(name) if holder.type == "ARMATURE" else None
        if pb is None:
            continue
        q = Quaternion(value)
        if pb.rotation_mode == "QUATERNION":
            pb.rotation_quaternion = q
        elif pb.rotation_mode == "AXIS_ANGLE":
            axis, angle = q.to_axis_angle()
            pb.rotation_axis_angle = (angle, *axis)
        else:
            pb.rotation_euler = q.to_euler(pb.rotation_mode)
    if forget_them and HELD in holder:
        del holder[HELD]


def forget(obj, first: int, last: int, keep: set[str] = frozenset()) -> int:
    """Remove the gestures' bone and object keys a run on ``obj`` wrote in
    [first, last] (a new run of the line without them), but on the bones
    and paths in ``keep``; how many keys went."""
    removed = 0
    for holder in {o for o in (obj, armature_of(obj)) if o is not None}:
        if keying.record_owner(holder, RECORD) not in ("", obj.name):
            continue
        for name, spans in keying.recorded_ranges(holder, RECORD).items():
            index, path = name.split(":", 1)
            if any(path.startswith(_bone_path(k)) or path == k for k in keep):
                continue
            fc = compat.find_fcurve(holder, path, int(index))
            for a, b in spans if fc is not None else []:
                lo, hi = max(a, first), min(b, last)
                if lo <= hi:
                    removed += keying.replace_range(fc, lo, hi)
        if not keep:
            _restore(holder, forget_them=False)
    return removed


def clear(obj) -> int:
    """Remove the gestures' bone and object keys a run on ``obj`` wrote."""
    removed = 0
    for holder in {o for o in (obj, armature_of(obj)) if o is not None}:
        owner = keying.record_owner(holder, RECORD)
        if owner is not None and owner in ("", obj.name):
            removed += keying.clear_owned(holder, RECORD)["keys"]
            _restore(holder)
    return removed


def bake(obj) -> None:
    """Make the gestures' bone and object keys a run on ``obj`` wrote plain
    keys: their record goes, so Clear no longer removes them."""
    for holder in {o for o in (obj, armature_of(obj)) if o is not None}:
        if keying.record_owner(holder, RECORD) in ("", obj.name):
            del holder[RECORD]
            if HELD in holder:
                del holder[HELD]


def wrote(obj) -> bool:
    """Whether a run on ``obj`` keyed gestures on its armature or object."""
    return any(keying.record_owner(o, RECORD) in ("", obj.name) for o in (obj, armature_of(obj)) if o is not None
               and keying.record_owner(o, RECORD) is not None)


__all__ = ["OBJECT_TURN", "RECORD", "animated", "armature_of", "bake", "channels", "clear", "describe", "forget",
           "lone_head", "write", "wrote"]
