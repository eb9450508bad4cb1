"""A line's keys: a :class:`.output.Result` turned into one curve per thing
a target keys, on every frame of the line.

The Blender layer only writes what this module gives it.  For a mesh
(:func:`mesh_keys`) the viseme curves go through the mesh's mapping onto its
shape keys and the expression's action units onto the keys the naming
conventions found for them; where the two meet on /p b m/ one gives way to
the other, as the rig's closure rule says (a rig whose basis shows closed
lips: the mouth's expression keys give way; else the closing pose's pressing
keys are sealed by the expression); the two are combined, and the rig's way
of closing the lips is applied last.  Keys the user animates on the
expression's side are left to the user.  For an armature
(:func:`rig_keys`) the mapped poses and properties get the closure alone,
and the poses that shut the lips are named (:func:`closing_names`) for
the blending of the bones.

The result, :class:`LineKeys`, is a list of :class:`Channel` values on the
line's frames.  The gestures beside speech (:func:`with_gestures`: blinks
and gaze on shape keys, brow raises on the expression's brow keys) add
channels driven by :data:`GESTURE`, and name the bones that turn (head,
neck, eyes) with their turns; what shifts or warps the keys (hand edits
kept over a new run) maps channels to channels; the Blender layer keys
whatever channels it is given.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass, field

import numpy as np

from . import conventions, expression, gestures, visemes
from . import mapping as mapping_mod
from .output import Result

#: What drives a channel.
SPEECH = "speech"
EXPRESSION = "expression"
GESTURE = "gesture"


@dataclass
class Channel:
    """One keyed value over the line: ``name`` (a shape key; on an armature a
    pose asset or a property) and its value on each of the line's frames,
    0-1.  ``drivers`` says what moves it: :data:`SPEECH`, :data:`EXPRESSION`
    or both (a key speech and the expression share)."""

    name: str
    values: np.ndarray
    drivers: tuple[str, ...] = (SPEECH,)


@dataclass
class LineKeys:
    """What a line keys on one target: its channels on the line's frames
    (``times``: s from the line's start, one a frame), and what the run's
    report says about them."""

    times: np.ndarray
    channels: list[Channel] = field(default_factory=list)
    units: list[str] = field(default_factory=list)            # the expression's action units keyed
    expression_keys: list[str] = field(default_factory=list)  # the keys they drive
    no_key: list[str] = field(default_factory=list)           # its units the target has no key for
    kept: list[str] = field(default_factory=list)             # expression keys left to the user's animation
    #: Keys the expression may drive that this run does not (the keys an
    #: earlier run wrote there on these frames go).
    dropped: list[str] = field(default_factory=list)
    closing: list[str] = field(default_factory=list)          # the names that shut the lips (/p b m)
    closure: np.ndarray = field(default_factory=lambda: np.zeros(0))   # per frame: how shut the lips are, 0-1
    #: The bones the gestures turn: bone -> (frames, 4) quaternions in the character's frame.
    turns: dict[str, np.ndarray] = field(default_factory=dict)
    gesture_keys: list[str] = field(default_factory=list)      # the shape keys the gestures drive
    blinks: int = 0                                            # blinks keyed (0: no blink key, or none in the line)
    gesture_kept: list[str] = field(default_factory=list)      # gesture channels left to the user's animation
    gesture_missing: list[str] = field(default_factory=list)   # what the target has no channel for, in words

    @property
    def frames(self) -> int:
        return len(self.times)

    @property
    def names(self) -> list[str]:
        return [c.name for c in self.channels]

    def table(self) -> np.ndarray:
        """The channels' values as one (frames, channels) array."""
        if not self.channels:
            return np.zeros((self.frames, 0))
        return np.stack([c.values for c in self.channels], axis=1)

    def driven_only_by(self, driver: str) -> list[str]:
        """The channels ``driver`` alone moves."""
        return [c.name for c in self.channels if c.drivers == (driver,)]


def closing_names(vset: visemes.VisemeSet, mapping: dict[str, dict[str, float]]) -> list[str]:
    """The names the visemes of /p b m/ drive (the poses that shut the
    lips), in that order, each once."""
    out = []
    for phone in ("P", "B", "M"):
        for v in vset.phonemes.get(phone, []):
            out += [k for k in mapping.get(v, {}) if k not in out]
    return out


def mesh_keys(result: Result, mapping: dict[str, dict[str, float]], closure: conventions.Closure,
              face: dict[str, dict[str, float]] | None = None, animated: Collection[str] = ()) -> LineKeys:
    """A mesh's shape-key curves for ``result``: the speech through
    ``mapping`` (viseme -> {shape key: weight}), the expression through
    ``face`` (action unit -> {shape key: weight}, as
    :func:`.conventions.expression_match` found them), under the mesh's
    ``closure`` rule.  ``animated`` are the shape keys the user animates:
    the expression leaves them alone (speech keys its own keys whatever)."""
    face = face or {}
    names, values = mapping_mod.shape_key_curves(result.curves, result.viseme_set.visemes, mapping)
    speech = list(names)
    units = [u for u in result.expression if u in face]
    no_key = [u for u in result.expression if u not in face]
    ex_names, ex_values = expression.key_curves({u: result.expression[u] for u in units}, face, len(values))
    kept = [k for k in ex_names if k not in speech and k in animated]
    cols = [j for j, k in enumerate(ex_names) if k not in kept]
    ex_names, ex_values = [ex_names[j] for j in cols], ex_values[:, cols]
    phones = [(p.phone, p.start, p.end) for p in result.alignment.phones]
    lower = {k for u, mix in face.items() if expression.lower_face(u) for k in mix}
    if closure.relax == "others":
        # The basis shows closed lips: the mouth's expression keys open on /p b m/ only as far as it does.
        ex_values = expression.give_way(ex_names, ex_values, lower, result.times, phones)
    else:
        # The closing pose presses the lips only as far as the mouth's expression does not hold them together.
        pressing = set(mapping.get(closure.viseme, {})) - set(closure.relative) - closure.relaxed_keys(mapping)
        values = expression.seal(names, values, pressing, ex_names, ex_values, lower, result.times, phones)
    names, values = expression.combine(names, values, ex_names, ex_values)
    names, values = conventions.apply_closure(names, values, result.closure, closure, mapping)
    by_speech, by_face = set(speech), set(ex_names)
    channels = [Channel(k, values[:, j], tuple(d for d, keys in ((SPEECH, by_speech), (EXPRESSION, by_face))
                                              if k in keys)) for j, k in enumerate(names)]
    dropped = sorted({k for mix in face.values() for k in mix} - set(names) - set(kept))
    return LineKeys(result.times, channels, units=units, expression_keys=ex_names, no_key=no_key, kept=kept,
                    dropped=dropped)


def rig_keys(result: Result, mapping: dict[str, dict[str, float]], closure: conventions.Closure) -> LineKeys:
    """An armature's curves for ``result``: its mapped poses and properties
    (``mapping``: viseme -> {name: weight}) under its ``closure`` rule, with
    the poses that shut the lips and how shut they are on each frame, for
    the blending of the bones."""
    names, values = mapping_mod.shape_key_curves(result.curves, result.viseme_set.visemes, mapping)
    names, values = conventions.apply_closure(names, values, result.closure, closure, mapping)
    return LineKeys(result.times, [Channel(k, values[:, j]) for j, k in enumerate(names)],
                    closing=closing_names(result.viseme_set, mapping), closure=result.closure)


def with_gestures(line: LineKeys, motion: gestures.Motion | None, found: gestures.Channels,
                  face: dict[str, dict[str, float]] | None = None, animated: Collection[str] = (),
                  head_elsewhere: bool = False) -> LineKeys:
    """``line`` with the gestures of ``motion`` on the channels ``found``
    (:func:`.gestures.match`): the blink and look keys, the brow raises on
    the keys ``face`` shows the brow units with (on top of the expression
    there: the larger of the two), and the bones' turns.  Shape keys and
    bones in ``animated`` (the user's own animation) are left alone and
    listed in ``gesture_kept``; ``head_elsewhere``: the head turns by other
    means than a bone (a lone head mesh's object).  With no motion (gestures
    off) ``line`` is returned as it is."""
    if motion is None:
        return line
    animated = set(animated)
    curves = gestures.shape_key_curves(motion, found)
    for unit in gestures.table()["brow_units"]:
        for key, w in (face or {}).get(unit, {}).items():
            v = np.clip(motion.brow * w, 0, 1)
            curves[key] = np.maximum(curves[key], v) if key in curves else v
    by_name = {c.name: c for c in line.channels}
    for key, values in curves.items():
        if key in animated:
            line.gesture_kept.append(key)
            continue
        if key in by_name:
            c = by_name[key]
            if SPEECH in c.drivers:
                continue   # speech owns its keys
            c.values = np.maximum(c.values, values)
            c.drivers = c.drivers + (GESTURE,)
        else:
            line.channels.append(Channel(key, np.asarray(values, dtype=float), (GESTURE,)))
        line.gesture_keys.append(key)
    for bone, q in gestures.bone_turns(motion, found).items():
        if bone in animated:
            line.gesture_kept.append(bone)
        else:
            line.turns[bone] = q
    line.gesture_missing = found.missing(head_elsewhere)
    lids = {k for role, k in found.shape_keys.items() if role.startswith("blink")}
    line.blinks = len(motion.blinks) if lids & set(line.gesture_keys) else 0
    return line


__all__ = ["Channel", "EXPRESSION", "GESTURE", "LineKeys", "SPEECH", "closing_names", "mesh_keys", "rig_keys",
           "with_gestures"]
