"""Shape-key F-curves written in bulk, without touching anything else.

Only the frames of the lip-synced range are replaced on the shape keys the
mapping drives; keys outside that range, other F-curves, drivers and the
action the user assigned stay as they were.  What the add-on wrote is
recorded on the Key datablock (the ``emotive_lipsync`` custom property), so
*Clear* removes exactly that and nothing the user keyed.
"""

from __future__ import annotations

import json

import bpy
import numpy as np

from ..engine import keys as key_reduction
from . import compat

RECORD = "emotive_lipsync"
GROUP = "Lip Sync"


def data_path(shape_key: str) -> str:
    return f'key_blocks["{bpy.utils.escape_identifier(shape_key)}"].value'


def _record(key) -> dict:
    try:
        rec = json.loads(key.get(RECORD, "{}"))
    except (TypeError, ValueError):
        rec = {}
    rec.setdefault("ranges", {})
    rec.setdefault("created", [])
    return rec


def _remove_range(fc, first: float, last: float) -> int:
    kp = fc.keyframe_points
    n = len(kp)
    if n == 0:
        return 0
    co = np.empty(2 * n)
    kp.foreach_get("co", co)
    frames = co[0::2]
    doomed = np.flatnonzero((frames >= first - 1e-4) & (frames <= last + 1e-4))
    for i in doomed[::-1]:
        kp.remove(kp[int(i)], fast=True)
    return len(doomed)


def write(obj, shape_keys: list[str], values: np.ndarray, first_frame: int, tolerance: float = 0.0,
          label: str = "") -> dict:
    """Key ``values`` (frames x shape keys) on ``obj`` from ``first_frame``.

    Returns counts: keys written, keys replaced, F-curves created.
    """
    key = obj.data.shape_keys
    n = values.shape[0]
    last = first_frame + n - 1
    rec = _record(key)
    written = replaced = created = 0
    for j, name in enumerate(shape_keys):
        path = data_path(name)
        is_new = compat.find_fcurve(key, path) is None
        fc = compat.ensure_fcurve(key, path, f"{obj.name}_LipSync", GROUP)
        if is_new:
            created += 1
            if name not in rec["created"]:
                rec["created"].append(name)
        replaced += _remove_range(fc, first_frame, last)
        idx = key_reduction.reduce(values[:, j], tolerance)
        kp = fc.keyframe_points
        old = len(kp)
        kp.add(len(idx))
        co = np.empty(2 * (old + len(idx)))
        if old:
            kp.foreach_get("co", co)  # fills the old points; the new tail is overwritten below
        co[2 * old::2] = first_frame + idx
        co[2 * old + 1::2] = values[idx, j]
        kp.foreach_set("co", co)
        if tolerance <= 0:
            # A key on every frame: linear between them is exact and stops
            # Bezier handles overshooting past 0 or 1.
            interp = np.empty(old + len(idx), dtype=np.int32)
            kp.foreach_get("interpolation", interp)
            interp[old:] = bpy.types.Keyframe.bl_rna.properties["interpolation"].enum_items["LINEAR"].value
            kp.foreach_set("interpolation", interp)
        fc.update()
        written += len(idx)
        spans = rec["ranges"].setdefault(name, [])
        if [first_frame, last] not in spans:
            spans.append([first_frame, last])
    rec.setdefault("runs", []).append({"label": label, "first": first_frame, "last": last})
    rec["runs"] = rec["runs"][-50:]
    key[RECORD] = json.dumps(rec)
    return {"keys": written, "replaced": replaced, "fcurves_created": created,
            "first_frame": first_frame, "last_frame": last, "shape_keys": len(shape_keys)}


def clear(obj) -> dict:
    """Remove the keys the add-on wrote on ``obj``.  F-curves it created and
    that hold nothing else go too; the user's keys stay."""
    key = obj.data.shape_keys if obj.type == "MESH" else None
    if key is None or RECORD not in key:
        return {"keys": 0, "fcurves_removed": 0}
    rec = _record(key)
    removed = dropped = 0
    for name, spans in rec["ranges"].items():
        fc = compat.find_fcurve(key, data_path(name))
        if fc is None:
            continue
        for first, last in spans:
            removed += _remove_range(fc, first, last)
        if name in rec["created"] and len(fc.keyframe_points) == 0 and not fc.modifiers:
            compat.remove_fcurve(key, fc)
            dropped += 1
        else:
            fc.update()
    del key[RECORD]
    return {"keys": removed, "fcurves_removed": dropped}


def lipsynced(obj) -> bool:
    key = getattr(obj.data, "shape_keys", None) if obj is not None and obj.type == "MESH" else None
    return key is not None and RECORD in key
