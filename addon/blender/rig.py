"""Bone rigs as lip-sync targets: an armature's mouth is moved by pose assets
and custom properties instead of shape keys.

What a viseme may drive on an armature, by name (the names Auto-Map matches
with the shape-key naming conventions, and the mapping rows hold):

* a **pose asset**: an Action marked as an asset (Blender's pose library)
  that keys some of this armature's bones, by the Action's name;
* a **custom property** with a number, on the armature object (its name) or
  on a pose bone (``bone:property``): Daz face units brought in by the
  Diffeomorphic importer, or properties a rig drives its face from.

Poses are blended by :mod:`..engine.pose_blend` and keyed on the pose bones'
channels; properties are keyed like shape keys.
"""

from __future__ import annotations

import re

import bpy
import numpy as np

from ..engine import pose_blend
from ..engine.errors import LipSyncError
from . import compat

#: The first name of :func:`names`, standing where a mesh's Basis key stands.
REST = "(Rest Pose)"

_BONE_PATH = re.compile(r'^pose\.bones\["((?:[^"\\]|\\.)*)"\]\.(' + "|".join(
    ("location", "scale") + pose_blend.ROTATIONS) + r")$")


def _unescape(s: str) -> str:
    return re.sub(r"\\(.)", r"\1", s)


def _esc(s: str) -> str:
    return bpy.utils.escape_identifier(s)


def _number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _own(prop: str) -> bool:
    """A custom property the add-on or Blender keeps for itself."""
    return prop.startswith(("_", "emotive_lipsync"))


def read_pose(action, bones) -> pose_blend.Pose:
    """The pose an asset holds for the bones in ``bones``: bone -> {channel:
    values} at the action's first frame; channels at their rest value are
    left out (the pose does not move them)."""
    frame = action.frame_range[0]
    found: dict[tuple[str, str], dict[int, float]] = {}
    for fc in compat.action_fcurves(action):
        m = _BONE_PATH.match(fc.data_path)
        if m is None:
            continue
        bone = _unescape(m.group(1))
        if bone in bones:
            found.setdefault((bone, m.group(2)), {})[fc.array_index] = fc.evaluate(frame)
    pose: pose_blend.Pose = {}
    for (bone, ch), comps in found.items():
        rest = pose_blend.REST[ch]
        value = [comps.get(i, r) for i, r in enumerate(rest)]
        if np.allclose(value, rest, atol=1e-6):
            continue
        pose.setdefault(bone, {})[ch] = value
    return pose


def pose_assets(obj) -> dict[str, object]:
    """The file's pose assets that key some of ``obj``'s bones, by name."""
    bones = set(obj.pose.bones.keys()) if obj.pose is not None else set()
    out = {}
    for action in bpy.data.actions if bones else []:
        if action.asset_data is None:
            continue
        for fc in compat.action_fcurves(action):
            m = _BONE_PATH.match(fc.data_path)
            if m and _unescape(m.group(1)) in bones:
                out[action.name] = action
                break
    return out


def properties(obj) -> dict[str, str]:
    """The armature's number custom properties: name -> data path."""
    out = {}
    for prop in obj.keys():
        if not _own(prop) and _number(obj[prop]):
            out[prop] = f'["{_esc(prop)}"]'
    for pb in obj.pose.bones if obj.pose is not None else []:
        for prop in pb.keys():
            if not _own(prop) and _number(pb[prop]):
                out[f"{pb.name}:{prop}"] = f'pose.bones["{_esc(pb.name)}"]["{_esc(prop)}"]'
    return out


def names(obj) -> list[str]:
    """What a viseme may drive on ``obj``, after :data:`REST` (as a mesh's
    key blocks come after its Basis)."""
    return [REST] + sorted(pose_assets(obj)) + sorted(properties(obj))


def check(obj) -> list[str]:
    """The armature's names (:func:`names`), or a clear error."""
    out = names(obj)
    if len(out) < 2:
        raise LipSyncError(f"armature {obj.name!r} has no pose assets or number properties to animate: pose each "
                           "mouth shape and save it as a pose asset (Pose Library), or add custom properties")
    ad = obj.animation_data
    if ad is not None and ad.action is not None and ad.action.asset_data is not None:
        raise LipSyncError(f"armature {obj.name!r} plays the pose asset {ad.action.name!r} as its action; lip sync "
                           "would key into the asset: assign another action (or none) to the armature. "
                           "Nothing was changed")
    return out


def channels(obj, driven: list[str], values: np.ndarray, closing: list[str], closure: np.ndarray
             ) -> tuple[list[tuple[str, int]], np.ndarray]:
    """The F-curves to key on ``obj``: ``driven`` names with their curves
    ``values`` (frames, names) -> [(data path, index)] and their values
    (frames, channels).  Poses are blended (:func:`..engine.pose_blend.blend`),
    the ``closing`` ones shown alone at a full ``closure``; properties are
    keyed as they come."""
    poses = pose_assets(obj)
    props = properties(obj)
    pose_cols = [j for j, n in enumerate(driven) if n in poses]
    out_paths: list[tuple[str, int]] = []
    cols: list[np.ndarray] = []
    if pose_cols:
        bones = set(obj.pose.bones.keys())
        read = [read_pose(poses[driven[j]], bones) for j in pose_cols]
        closing_cols = [i for i, j in enumerate(pose_cols) if driven[j] in closing]
        w = pose_blend.with_closure(values[:, pose_cols], closure, closing_cols)
        modes = {b: obj.pose.bones[b].rotation_mode for pose in read for b in pose}
        for (bone, ch), arr in pose_blend.blend(read, w, modes).items():
            path = f'pose.bones["{_esc(bone)}"].{ch}'
            for i in range(arr.shape[1]):
                out_paths.append((path, i))
                cols.append(arr[:, i])
    for j, n in enumerate(driven):
        if n in props:
            out_paths.append((props[n], 0))
            cols.append(values[:, j])
    frames = values.shape[0]
    return out_paths, (np.stack(cols, axis=1) if cols else np.zeros((frames, 0)))
