"""An animator's polish kept over Generate: the curves a run keyed are
remembered beside the keys, and the next run of the line lays the
animator's changes on its own curves (the maths: :mod:`..engine.edits`).

What is kept, per target and line, in the ``emotive_lipsync_lines`` custom
property of the mesh's Key datablock (an armature's: of the object, where
the record of its keys is): a group per line, each holding ``meta`` (JSON:
the line, its first frame and frame rate, its words and phones, the names
of its channels, which frames were keyed) and ``values`` (the curves as
drawn, frames x channels, one float array).  A line is its sound strip, or
its audio file; a line keyed where no remembered line of that name is
takes the remembered line its frames overlap most (a new take on another
strip or file).

This module reads the curves and writes the keys (through :mod:`.keying`);
it changes nothing else.  Frames in a locked range keep their keys: the
line is keyed around them, and the keys at the range's edges are made (a
Bezier segment cut where it crosses the edge) and their handles fixed so
that the curve inside draws as it did.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field

import numpy as np

from ..engine import edits as engine_edits
from ..engine import fcurve_eval
from ..engine.alignment import Alignment
from ..engine.edits import DISCARD, Take, Timing
from ..engine.errors import LipSyncError
from . import compat, keying

RECORD = "emotive_lipsync_lines"


def line_id(clip) -> str:
    """What names a line: its sound strip, else its audio file, else its label."""
    if clip.strip:
        return f"strip:{clip.strip}"
    if clip.audio_path:
        return f"file:{os.path.normcase(os.path.abspath(clip.audio_path))}"
    return f"label:{clip.label}"


def check_lock(lock) -> tuple[int, int] | None:
    """A locked range as (first, last) frames, or None; a clear error for a bad one."""
    if lock is None:
        return None
    first, last = (int(x) for x in lock)
    if last < first:
        raise LipSyncError(f"the locked frames {first}-{last} end before they start: give FIRST-LAST, "
                           "FIRST no later than LAST")
    return first, last


def parse_lock(text: str) -> tuple[int, int] | None:
    """``"120-150"`` -> (120, 150); ``""`` or ``"none"`` -> None."""
    text = (text or "").strip()
    if not text or text.lower() == "none":
        return None
    parts = text.replace(" ", "").split("-")
    # A negative first frame is allowed: "-10-20", "-20--10".
    if parts and parts[0] == "":
        parts = ["-" + parts[1]] + parts[2:]
    if len(parts) == 3 and parts[1] == "":
        parts = [parts[0], "-" + parts[2]]
    try:
        first, last = (int(p) for p in parts)
    except ValueError:
        raise LipSyncError(f"locked frames {text!r}: give FIRST-LAST, whole frame numbers (120-150)") from None
    return check_lock((first, last))


def check_mode(mode: str) -> str:
    """``keep`` or ``discard``, or a clear error."""
    if mode not in engine_edits.MODES:
        raise LipSyncError(f"hand edits {mode!r}: give {' or '.join(engine_edits.MODES)}")
    return mode


# --- where a target's curves are ------------------------------------------------------

class _Target:
    """A target's channels by name: a mesh's shape keys (on its Key
    datablock), an armature's channels (``index:data path``, on the object)."""

    def __init__(self, obj):
        self.obj = obj
        self.rig = obj.type == "ARMATURE"
        self.id_data = obj if self.rig else obj.data.shape_keys

    def path(self, name: str) -> tuple[str, int]:
        if self.rig:
            index, path = name.split(":", 1)
            return path, int(index)
        return keying.data_path(name), 0

    def fcurve(self, name: str):
        return compat.find_fcurve(self.id_data, *self.path(name)) if self.id_data is not None else None


def _keys(fc) -> np.ndarray:
    co = np.empty(2 * len(fc.keyframe_points))
    fc.keyframe_points.foreach_get("co", co)
    return co.reshape(-1, 2)


def _curve(fc, frames: np.ndarray) -> np.ndarray:
    """What the keys of ``fc`` draw at ``frames`` (its modifiers left out:
    they are not keys, and stay on the curve)."""
    if not len(fc.keyframe_points):
        return np.zeros(len(frames))
    muted = [m for m in fc.modifiers if not m.mute]
    for m in muted:
        m.mute = True
    try:
        return keying.drawn(fc, frames)
    finally:
        for m in muted:
            m.mute = False


def _read(target: _Target, names: list[str], frames: np.ndarray):
    """The channels' curves now on ``frames`` and the frames of their keys
    (name -> array), for the channels that still have an F-curve."""
    values, keys = {}, {}
    for name in names:
        fc = target.fcurve(name)
        if fc is None:
            continue
        values[name] = _curve(fc, frames)
        keys[name] = _keys(fc)[:, 0]
    return values, keys


# --- the record -------------------------------------------------------------------------

def _slot(line: str) -> str:
    return hashlib.sha1(line.encode("utf-8")).hexdigest()[:16]


@dataclass
class Line:
    """A line remembered on a target: what names it (:func:`line_id`), its
    label for people, and its :class:`..engine.edits.Take`."""

    line: str
    label: str
    take: Take


def takes(obj) -> dict[str, Line]:
    """The lines remembered on ``obj``, by slot.  A slot that cannot be
    read is left out (it is rewritten on the next run)."""
    owner = _Target(obj).id_data
    group = owner.get(RECORD) if owner is not None else None
    out = {}
    for slot in group.keys() if group is not None and hasattr(group, "keys") else []:
        try:
            meta = json.loads(group[slot]["meta"])
            out[slot] = Line(meta["line"], meta.get("label", ""), Take.from_meta(meta, group[slot]["values"]))
        except (KeyError, TypeError, ValueError):
            continue
    return out


def _store(obj, slot: str, line: str, label: str, take: Take | None) -> None:
    owner = _Target(obj).id_data
    if RECORD not in owner or not hasattr(owner[RECORD], "keys"):
        owner[RECORD] = {}
    group = owner[RECORD]
    if take is None or not take.values.size:
        if slot in group:
            del group[slot]
        return
    meta = {"line": line, "label": label, **take.meta()}
    group[slot] = {"meta": json.dumps(meta, separators=(",", ":")), "values": take.values.ravel().tolist()}


def forget(obj) -> int:
    """Forget every line remembered on ``obj`` (Clear, Bake); how many there were."""
    n = remembered(obj)
    owner = _Target(obj).id_data if obj is not None and obj.type in ("MESH", "ARMATURE") else None
    if owner is not None and RECORD in owner:
        del owner[RECORD]
    return n


def remembered(obj) -> int:
    """How many lines ``obj`` remembers the curves of (counted, not read:
    the panel asks on every redraw)."""
    owner = _Target(obj).id_data if obj is not None and obj.type in ("MESH", "ARMATURE") else None
    group = owner.get(RECORD) if owner is not None else None
    return len(group.keys()) if group is not None and hasattr(group, "keys") else 0


def _match(found: dict[str, Line], line: str, first: int, last: int) -> str | None:
    """The slot of the remembered line this one re-keys: the same line,
    else the one its frames overlap most, over half of the shorter of the
    two at least (a new take over the old; not the next line, touching it)."""
    slot = _slot(line)
    if slot in found:
        return slot
    best, most = None, 0
    for s, remembered_line in found.items():
        take = remembered_line.take
        overlap = min(last, take.last) - max(first, take.first) + 1
        if overlap > most and 2 * overlap >= min(last - first, take.last - take.first) + 1:
            best, most = s, overlap
    return best


# --- the locked frames ------------------------------------------------------------------

_FREE = "FREE"


def _freeze(kp, i: int) -> None:
    """Key ``i`` keeps its handles where they are, whatever its neighbours become."""
    k = kp[i]
    left, right = tuple(k.handle_left), tuple(k.handle_right)
    k.handle_left_type, k.handle_right_type = _FREE, _FREE
    k.handle_left, k.handle_right = left, right


def _edge(fc, frame: float, inside_after: bool) -> None:
    """Make ``fc`` hold a key on ``frame``, the edge of a locked range
    (inside it after the edge when ``inside_after``), drawing the curve as
    it was, and fix the handles of the keys the locked side depends on."""
    kp = fc.keyframe_points
    co = _keys(fc)
    if not len(co):
        return
    at = np.flatnonzero(np.abs(co[:, 0] - frame) < 1e-4)
    if len(at):
        _freeze(kp, int(at[0]))
        return
    k = int(np.searchsorted(co[:, 0], frame)) - 1
    if k < 0 or k + 1 >= len(co):
        return   # the range's edge lies past the curve's keys: it holds its end value there
    a, b = kp[k], kp[k + 1]
    # The key on the locked side keeps its handles before anything moves.
    _freeze(kp, k + 1 if inside_after else k)
    bezier = a.interpolation == "BEZIER"
    if bezier:
        cut = fcurve_eval.split(tuple(a.co), tuple(a.handle_right), tuple(b.handle_left), tuple(b.co), frame)
        value = float(cut[2][1])
    else:
        value = float(keying.drawn(fc, np.array([frame]))[0])
    interpolation, easing = a.interpolation, a.easing
    # Some Blenders reshape the neighbours' handles as they insert a key:
    # every handle is set after the insertion.
    kp.insert(frame, value, options={"FAST"})
    a, new, b = kp[k], kp[k + 1], kp[k + 2]
    new.interpolation, new.easing = interpolation, easing
    if bezier:
        for key, side in ((a, "right"), (new, "left"), (new, "right"), (b, "left")):
            setattr(key, f"handle_{side}_type", _FREE)
        a.handle_right, new.handle_left, new.handle_right, b.handle_left = (tuple(p) for p in cut[[0, 1, 3, 4]])
    else:
        _freeze(kp, k + 1)
    fc.update()


def _hold_edges(target: _Target, names: list[str], lock: tuple[int, int], first: int, last: int) -> None:
    """Hold the curves of ``names`` at the edges of ``lock`` that the line's
    new keys (frames ``first`` to ``last``) border."""
    for name in names:
        fc = target.fcurve(name)
        if fc is not None:
            if lock[0] > first:
                _edge(fc, lock[0], True)
            if lock[1] < last:
                _edge(fc, lock[1], False)


def _pieces(first: int, last: int, lock: tuple[int, int] | None) -> list[tuple[int, int]]:
    """The frames of [first, last] outside ``lock``, as ranges."""
    if lock is None or lock[1] < first or lock[0] > last:
        return [(first, last)]
    return [(a, b) for a, b in ((first, lock[0] - 1), (lock[1] + 1, last)) if a <= b]


# --- a line keyed --------------------------------------------------------------------------

@dataclass
class Outcome:
    """What a line's keying did with the edits on one target."""

    target: str
    carried: engine_edits.Carried | None = None
    discarded: int = 0
    lock: tuple[int, int] | None = None


@dataclass
class Report:
    """The edits of a run over its targets (the face and its companions), in words."""

    outcomes: list[Outcome] = field(default_factory=list)

    def message(self) -> str:
        done = [o for o in self.outcomes if o.carried is not None]
        parts = []
        total = engine_edits.Carried(np.zeros(0))
        for o in done:
            total.kept += o.carried.kept
            total.moved += o.carried.moved
            total.locked += o.carried.locked
            prefix = "" if o is self.outcomes[0] else f"{o.target}: "
            total.dropped += [prefix + d for d in o.carried.dropped]
        if total.message():
            parts.append(total.message())
        discarded = sum(o.discarded for o in self.outcomes)
        if discarded:
            parts.append(f"hand edits: {discarded} discarded")
        lock = self.outcomes[0].lock if self.outcomes else None
        if lock is not None:
            parts.append(f"frames {lock[0]}-{lock[1]} locked (left as they were)")
        return "; ".join(parts)


def key_line(obj, names: list[str], values: np.ndarray, first: int, *, tolerance: float, label: str, line: str,
             alignment: Alignment, fps: float, mode: str = engine_edits.KEEP,
             lock: tuple[int, int] | None = None, forget_keys: list[str] = ()) -> tuple[dict, Outcome]:
    """Key ``values`` (frames x ``names``) on ``obj`` from ``first`` as
    :func:`.keying.write` (an armature: :func:`.keying.write_rig`) does,
    with the animator's edits of the line's last run laid on them (``mode``
    :data:`..engine.edits.KEEP`) or not (``DISCARD``), and the frames of
    ``lock`` left as they are.  ``forget_keys``: shape keys the run no
    longer drives, whose lip-sync keys on its frames go.  The run's curves
    and the line's ``alignment`` are remembered for the next.  Returns
    the keying's counts and what became of the edits."""
    target = _Target(obj)
    last = first + len(values) - 1
    fresh = np.asarray(values, dtype=np.float64)
    found = takes(obj) if target.id_data is not None else {}
    slot = _match(found, line, first, last)
    old = found[slot].take if slot is not None else None
    timing = Timing.of(alignment)
    outcome = Outcome(obj.name, lock=lock if lock is not None and lock[0] <= last and lock[1] >= first else None)
    final = fresh
    if old is not None:
        now, key_frames = _read(target, old.names, old.frames)
        edits = engine_edits.find(old, now, key_frames)
        if mode == DISCARD:
            outcome.discarded = len(edits)
        else:
            outcome.carried = engine_edits.carry(old, edits, timing, first, fps, names, fresh, outcome.lock)
            final = outcome.carried.values
    if outcome.lock is not None:
        _hold_edges(target, names + list(forget_keys), outcome.lock, first, last)
    counts = {"keys": 0, "replaced": 0, "fcurves_created": 0, "first_frame": first, "last_frame": last,
              "shape_keys": len(names)}
    if old is not None:
        counts["replaced"] += _clear_stale(target, old, first, last, outcome.lock)
    for a, b in _pieces(first, last, outcome.lock):
        rows = slice(a - first, b - first + 1)
        if target.rig:
            channels = [target.path(n) for n in names]
            got = keying.write_rig(obj, channels, final[rows], a, tolerance, label)
        else:
            keying.forget(obj, list(forget_keys), a, b)
            got = keying.write(obj, names, final[rows], a, tolerance, label)
        for k in ("keys", "replaced", "fcurves_created"):
            counts[k] += got[k]
    target = _Target(obj)      # the first keys of a mesh make its Key's action
    frames = first + np.arange(len(fresh))
    drawn, key_frames = _read(target, names, frames)
    drawn = np.stack([drawn.get(n, final[:, j]) for j, n in enumerate(names)], axis=1) if names else final
    kept = engine_edits.remembered(fresh, final, drawn, first, names, outcome.lock, old)
    every = tolerance <= 0 and outcome.lock is None
    take = Take(first, fps, timing, list(names), kept,
                None if every else {n: key_frames[n][(key_frames[n] >= first) & (key_frames[n] <= last)] - first
                                    for n in names if n in key_frames},
                outcome.carried.held if outcome.carried is not None else {})
    _remember(obj, slot, line, label, take, frames, names, drawn, outcome.lock)
    return counts, outcome


def _clear_stale(target: _Target, old: Take, first: int, last: int, lock: tuple[int, int] | None) -> int:
    """Remove the keys of the line's last run on the frames this run does
    not key (the strip moved, or the new take is shorter): the line is
    there no more.  How many keys went."""
    removed = 0
    for a, b in _pieces(old.first, old.last, (first, last)):
        for lo, hi in _pieces(a, b, lock):
            for name in old.names:
                fc = target.fcurve(name)
                if fc is not None:
                    removed += keying.replace_range(fc, lo, hi)
    return removed


def _remember(obj, slot: str | None, line: str, label: str, take: Take, frames, names, drawn, lock) -> None:
    """Keep ``take`` as the line's, in place of the one it re-keyed
    (``slot``); other lines keyed over the same frames take what is there
    now as theirs."""
    if slot is not None:
        _store(obj, slot, "", "", None)
    written = ~engine_edits.locked_frames(frames, lock)
    for other, had in takes(obj).items():
        if had.take.first <= frames[-1] and had.take.last >= frames[0]:
            _store(obj, other, had.line, had.label, had.take.rewritten(frames[written], names, drawn[written]))
    _store(obj, _slot(line), line, label, take)


def bake(obj) -> int:
    """Make the lip sync on ``obj`` plain keys: the remembered curves and
    the record of what the add-on keyed are forgotten, the keys (the
    generated curves with the edits on them) stay.  How many lines were
    remembered."""
    n = forget(obj)
    owner = obj if obj.type == "ARMATURE" else obj.data.shape_keys
    record = keying.RIG_RECORD if obj.type == "ARMATURE" else keying.RECORD
    if owner is not None and record in owner:
        del owner[record]
    return n


__all__ = ["Line", "RECORD", "Outcome", "Report", "bake", "check_lock", "check_mode", "forget", "key_line", "line_id",
           "parse_lock", "remembered", "takes"]
