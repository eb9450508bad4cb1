"""Shape-key F-curves (and a bone rig's channels) written in bulk, without
touching anything else.

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

from ..engine import fcurve_eval, key_reduction
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


# Every keyframe property that a rewrite must carry over for the user's keys.
_KEY_ATTRS = (("co", 2, np.float64), ("handle_left", 2, np.float64), ("handle_right", 2, np.float64),
              ("interpolation", 1, np.int32), ("handle_left_type", 1, np.int32),
              ("handle_right_type", 1, np.int32), ("type", 1, np.int32), ("easing", 1, np.int32),
              ("back", 1, np.float64), ("amplitude", 1, np.float64), ("period", 1, np.float64),
              ("select_control_point", 1, bool), ("select_left_handle", 1, bool),
              ("select_right_handle", 1, bool))
_EPS = 1e-4


def _get(kp, attr, size, dtype):
    arr = np.empty(len(kp) * size, dtype=dtype)
    kp.foreach_get(attr, arr)
    return arr.reshape(-1, size)


def key_frames(fc) -> np.ndarray:
    """The frames of ``fc``'s keys, read in bulk."""
    return _get(fc.keyframe_points, "co", 2, np.float64)[:, 0] if len(fc.keyframe_points) else np.zeros(0)


def replace_range(fc, first: float, last: float, frames=None, values=None, linear: bool = False) -> int:
    """Swap the keys of ``fc`` in [first, last] for new ones, in bulk.

    Keys outside the range keep every property (handles, interpolation,
    easing, key type, selection).  Returns how many keys were removed.
    ``frames=None`` only removes.
    """
    kp = fc.keyframe_points
    frames = np.zeros(0) if frames is None else np.asarray(frames, dtype=np.float64)
    values = np.zeros(0) if values is None else np.asarray(values, dtype=np.float64)
    n, m = len(kp), len(frames)
    saved, before, removed = {}, 0, 0
    if n:
        f = _get(kp, "co", 2, np.float64)[:, 0]
        keep = (f < first - _EPS) | (f > last + _EPS)
        removed = int(n - keep.sum())
        if removed == 0 and m == 0:
            return 0
        saved = {a: _get(kp, a, size, dt)[keep] for a, size, dt in _KEY_ATTRS}
        before = int((f[keep] < first).sum())
        kp.clear()
    k = len(saved["co"]) if saved else 0
    if k + m == 0:
        return removed
    kp.add(k + m)
    new = np.zeros(k + m, dtype=bool)
    new[before:before + m] = True
    for attr, size, dtype in _KEY_ATTRS:
        if attr == "co":
            arr = np.empty((k + m, 2))
            arr[new, 0], arr[new, 1] = frames, values
        elif k == 0 and not (attr == "interpolation" and linear):
            continue  # the new keys keep Blender's defaults
        else:
            arr = _get(kp, attr, size, dtype)
        if k:
            arr[~new] = saved[attr]
        if attr == "interpolation" and linear:
            arr[new] = _interpolation("LINEAR")
        kp.foreach_set(attr, arr.ravel())
    fc.update()
    return removed


def _interpolation(name: str) -> int:
    return bpy.types.Keyframe.bl_rna.properties["interpolation"].enum_items[name].value


def drawn(fc, frames: np.ndarray) -> np.ndarray:
    """What ``fc`` evaluates to at ``frames``, computed in bulk.

    The keys, handles and interpolations are read in bulk and evaluated by
    :func:`..engine.fcurve_eval.evaluate`; an F-curve with modifiers, fewer
    than two keys, another interpolation (easing, elastic ...) or frames
    past its keys extrapolated linearly is evaluated by Blender frame by
    frame."""
    kp = fc.keyframe_points
    frames = np.asarray(frames, dtype=np.float64)
    if not len(frames):
        return np.zeros(0)
    codes = {_interpolation(n): code for n, code in (("BEZIER", fcurve_eval.BEZIER), ("LINEAR", fcurve_eval.LINEAR),
                                                     ("CONSTANT", fcurve_eval.CONSTANT))}
    simple = len(kp) >= 2 and not len(fc.modifiers)
    if simple:
        ipo = _get(kp, "interpolation", 1, np.int32)[:, 0]
        co = _get(kp, "co", 2, np.float64)
        inside = ((frames >= co[0, 0]) & (frames <= co[-1, 0])).all()
        simple = np.isin(ipo, list(codes)).all() and (inside or fc.extrapolation == "CONSTANT")
    if not simple:
        return np.fromiter((fc.evaluate(f) for f in frames), float, len(frames))
    kinds = np.empty(len(ipo), dtype=np.int32)
    for blender, code in codes.items():
        kinds[ipo == blender] = code
    return fcurve_eval.evaluate(co, _get(kp, "handle_left", 2, np.float64), _get(kp, "handle_right", 2, np.float64),
                                kinds, frames)


def _hold_to_tolerance(fc, first: int, y: np.ndarray, idx: np.ndarray, tolerance: float,
                       rounds: int = 8) -> np.ndarray:
    """Keys of ``fc`` (frames ``first + idx``) such that the curve Blender
    draws stays within ``tolerance`` of ``y`` on every frame.

    The reduction measures straight lines between kept keys, but new keys
    are Bezier with automatic clamped handles: next to a hold (a closure's
    plateau, a peak) the handles are flat and the curve bulges past the
    line.  The F-curve itself is evaluated, and the worst frame of every
    span that strays too far becomes a key, until none does."""
    frames = first + np.arange(len(y), dtype=np.float64)
    for _ in range(rounds):
        err = np.abs(drawn(fc, frames) - y)
        bad = np.flatnonzero(err > tolerance)
        if not len(bad):
            break
        span = np.searchsorted(idx, bad, side="right") - 1
        worst = {}
        for f, s in zip(bad, span):
            if s not in worst or err[f] > err[worst[s]]:
                worst[s] = f
        idx = np.union1d(idx, list(worst.values()))
        replace_range(fc, first, first + len(y) - 1, first + idx, y[idx])
    return idx


def _write_curve(id_data, path: str, index: int, column: np.ndarray, first_frame: int, tolerance: float,
                 action_name: str) -> tuple[int, int]:
    """Key one F-curve of ``id_data`` from ``first_frame`` (see :func:`write`):
    (keys written, keys replaced)."""
    last = first_frame + len(column) - 1
    fc = compat.ensure_fcurve(id_data, path, action_name, GROUP, index)
    idx = key_reduction.reduce(column, tolerance)
    replaced = replace_range(fc, first_frame, last, first_frame + idx, column[idx], linear=tolerance <= 0)
    if tolerance > 0:
        idx = _hold_to_tolerance(fc, first_frame, column, idx, tolerance)
    return len(idx), replaced


def write(obj, shape_keys: list[str], values: np.ndarray, first_frame: int, tolerance: float = 0.0,
          label: str = "") -> dict:
    """Key ``values`` (frames x shape keys) on ``obj`` from ``first_frame``.

    With ``tolerance`` 0 every frame gets a linear key (exact, and no Bezier
    overshoot past 0 or 1); otherwise :func:`..engine.key_reduction.reduce` keeps the
    keys needed and Blender's default Bezier keys smooth between them, held
    within ``tolerance`` by :func:`_hold_to_tolerance`.
    Returns counts: keys written, keys replaced, F-curves created.
    """
    key = obj.data.shape_keys
    rec = _record(key)
    counts = _key_channels(key, rec, shape_keys, [(data_path(name), 0) for name in shape_keys], values,
                           first_frame, tolerance, f"{obj.name}_LipSync", label)
    key[RECORD] = json.dumps(rec)
    return counts


def _key_channels(id_data, rec: dict, names: list[str], channels: list[tuple[str, int]], values: np.ndarray,
                  first_frame: int, tolerance: float, action_name: str, label: str) -> dict:
    """Key each column of ``values`` on its channel (data path, index) of
    ``id_data`` and note in ``rec`` (the add-on's record, under ``names``)
    what was created and which frames were keyed; the counts :func:`write` returns."""
    last = first_frame + values.shape[0] - 1
    written = replaced = created = 0
    for j, (name, (path, index)) in enumerate(zip(names, channels)):
        if compat.find_fcurve(id_data, path, index) is None:
            created += 1
            if name not in rec["created"]:
                rec["created"].append(name)
        w, r = _write_curve(id_data, path, index, values[:, j], first_frame, tolerance, action_name)
        written += w
        replaced += r
        spans = rec["ranges"].setdefault(name, [])
        if [first_frame, last] not in spans:
            spans.append([first_frame, last])
    rec.setdefault("runs", []).append({"label": label, "first": first_frame, "last": last})
    rec["runs"] = rec["runs"][-50:]
    return {"keys": written, "replaced": replaced, "fcurves_created": created,
            "first_frame": first_frame, "last_frame": last, "shape_keys": len(names)}


# --- bone rigs ------------------------------------------------------------------
# An armature's record is kept on the object (its ``emotive_lipsync`` property
# holds the object's settings), its channels named "index:data path".

RIG_RECORD = "emotive_lipsync_keys"


def _rig_record(obj, record: str = RIG_RECORD) -> dict:
    try:
        rec = json.loads(obj.get(record, "{}"))
    except (TypeError, ValueError):
        rec = {}
    rec.setdefault("ranges", {})
    rec.setdefault("created", [])
    return rec


def _channel(name: str) -> tuple[str, int]:
    index, path = name.split(":", 1)
    return path, int(index)


def write_rig(obj, channels: list[tuple[str, int]], values: np.ndarray, first_frame: int, tolerance: float = 0.0,
              label: str = "") -> dict:
    """Key ``values`` (frames x channels) on an armature's ``channels`` (data
    path, index) from ``first_frame``, as :func:`write` keys shape keys.
    Channels an earlier run keyed over these frames and this one does not
    (a pose no longer mapped) lose those keys."""
    n = values.shape[0]
    last = first_frame + n - 1
    rec = _rig_record(obj)
    dropped = 0
    names = [f"{index}:{path}" for path, index in channels]
    for name, spans in rec["ranges"].items():
        if name in names:
            continue
        fc = compat.find_fcurve(obj, *_channel(name))
        for a, b in spans if fc is not None else []:
            lo, hi = max(a, first_frame), min(b, last)
            if lo <= hi:
                dropped += replace_range(fc, lo, hi)
    counts = _key_channels(obj, rec, names, channels, values, first_frame, tolerance, f"{obj.name}_LipSync", label)
    counts["replaced"] += dropped
    obj[RIG_RECORD] = json.dumps(rec)
    return counts


def write_owned(id_data, record: str, channels: list[tuple[str, int]], values: np.ndarray, first_frame: int,
                tolerance: float = 0.0, label: str = "", owner: str = "") -> dict:
    """Key ``values`` (frames x channels) on ``channels`` (data path, index)
    of ``id_data`` (an object) as :func:`write_rig` does, recorded under its
    own ``record`` property (the gestures' bones and object turns, kept
    apart from a rig's lip sync); ``owner`` names the object whose run
    wrote them, for its Clear.  Channels an earlier run recorded there over
    these frames and this one does not key lose those keys."""
    rec = _rig_record(id_data, record)
    last = first_frame + values.shape[0] - 1
    names = [f"{index}:{path}" for path, index in channels]
    dropped = 0
    for name, spans in rec["ranges"].items():
        fc = compat.find_fcurve(id_data, *_channel(name)) if name not in names else None
        for a, b in spans if fc is not None else []:
            lo, hi = max(a, first_frame), min(b, last)
            if lo <= hi:
                dropped += replace_range(fc, lo, hi)
    counts = _key_channels(id_data, rec, names, channels, values, first_frame, tolerance,
                           f"{id_data.name}_LipSync", label)
    counts["replaced"] += dropped
    if owner:
        rec["owner"] = owner
    id_data[record] = json.dumps(rec)
    return counts


def record_owner(id_data, record: str) -> str | None:
    """Which object's run wrote the keys recorded under ``record`` (None: none recorded)."""
    return _rig_record(id_data, record).get("owner", "") if record in id_data else None


def recorded_ranges(id_data, record: str) -> dict[str, list[list[int]]]:
    """Channel ("index:data path") -> the frame ranges recorded under ``record``."""
    return _rig_record(id_data, record)["ranges"] if record in id_data else {}


def clear_owned(id_data, record: str) -> dict:
    """Remove the keys recorded under ``record`` (see :func:`write_owned`)."""
    return _clear_rig(id_data, record) if record in id_data else {"keys": 0, "fcurves_removed": 0}


def _clear_rig(obj, record: str = RIG_RECORD) -> dict:
    rec = _rig_record(obj, record)
    removed = dropped = 0
    for name, spans in rec["ranges"].items():
        fc = compat.find_fcurve(obj, *_channel(name))
        if fc is None:
            continue
        for first, last in spans:
            removed += replace_range(fc, first, last)
        if name in rec["created"] and len(fc.keyframe_points) == 0 and not fc.modifiers:
            compat.remove_fcurve(obj, fc)
            dropped += 1
    del obj[record]
    return {"keys": removed, "fcurves_removed": dropped}


def user_animated(obj, shape_keys: list[str]) -> list[str]:
    """Of ``shape_keys``, those the user animates: a driver, or keys lip
    sync did not write (outside every range it recorded for that key).
    The expression layer leaves them alone."""
    key = obj.data.shape_keys
    rec = _record(key)
    drivers = key.animation_data.drivers if key.animation_data is not None else None
    out = []
    for name in shape_keys:
        path = data_path(name)
        if drivers is not None and drivers.find(path) is not None:
            out.append(name)
            continue
        fc = compat.find_fcurve(key, path)
        if fc is None or not len(fc.keyframe_points):
            continue
        f = _get(fc.keyframe_points, "co", 2, np.float64)[:, 0]
        ours = np.zeros(len(f), dtype=bool)
        for first, last in rec["ranges"].get(name, []):
            ours |= (f >= first - _EPS) & (f <= last + _EPS)
        if not ours.all():
            out.append(name)
    return out


def forget(obj, shape_keys: list[str], first: int, last: int) -> int:
    """Remove lip sync's keys in [first, last] from ``shape_keys`` (a new run
    that no longer drives them: an expression the new preset lacks); keys
    lip sync never wrote there are left.  Returns how many were removed."""
    key = obj.data.shape_keys
    rec = _record(key)
    removed = 0
    for name in shape_keys:
        spans = rec["ranges"].get(name, [])
        fc = compat.find_fcurve(key, data_path(name))
        if fc is None:
            continue
        for a, b in spans:
            lo, hi = max(a, first), min(b, last)
            if lo <= hi:
                removed += replace_range(fc, lo, hi)
    return removed


def clear(obj) -> dict:
    """Remove the keys the add-on wrote on ``obj``.  F-curves it created and
    that hold nothing else go too; the user's keys stay."""
    if obj.type == "ARMATURE":
        return _clear_rig(obj) if RIG_RECORD in obj else {"keys": 0, "fcurves_removed": 0}
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
            removed += replace_range(fc, first, last)
        if name in rec["created"] and len(fc.keyframe_points) == 0 and not fc.modifiers:
            compat.remove_fcurve(key, fc)
            dropped += 1
    del key[RECORD]
    return {"keys": removed, "fcurves_removed": dropped}


def lipsynced(obj) -> bool:
    if obj is not None and obj.type == "ARMATURE":
        return RIG_RECORD in obj
    key = getattr(obj.data, "shape_keys", None) if obj is not None and obj.type == "MESH" else None
    return key is not None and RECORD in key
