"""Every difference between the Blender versions the extension supports.

* Animation data: Blender 4.2-4.3 keep F-curves on ``Action.fcurves``.
  4.4 introduced slotted actions, where F-curves live in a channelbag per
  slot and layer; ``Action.fcurves`` still worked there for the first slot
  and was removed in 5.0.
  https://developer.blender.org/docs/release_notes/4.4/python_api/#slotted-actions
  https://developer.blender.org/docs/release_notes/5.0/python_api/
* Sequencer: ``SequenceEditor.sequences_all`` became ``strips_all`` in 4.4
  (``sequences_all`` was removed in 5.0).
  https://developer.blender.org/docs/release_notes/4.4/sequencer/
"""

from __future__ import annotations

import bpy

SLOTTED_ACTIONS = bpy.app.version >= (4, 4, 0)


# --- sequencer ---------------------------------------------------------------

def all_strips(scene):
    ed = scene.sequence_editor
    if ed is None:
        return []
    strips = getattr(ed, "strips_all", None)
    return list(strips if strips is not None else ed.sequences_all)


def sound_strips(scene):
    return [s for s in all_strips(scene) if s.type == "SOUND"]


# --- F-curves ----------------------------------------------------------------

def _channelbag(id_data, create: bool):
    ad = id_data.animation_data
    if ad is None or ad.action is None:
        return None
    action = ad.action
    if not SLOTTED_ACTIONS:
        return action  # Action itself has .fcurves
    slot = ad.action_slot
    if slot is None:
        if not create:
            return None
        slot = action.slots.new(id_type=id_data.id_type, name=id_data.name)
        ad.action_slot = slot
    for layer in action.layers:
        for strip in layer.strips:
            bag = strip.channelbag(slot, ensure=False)
            if bag is not None or create:
                return bag if bag is not None else strip.channelbag(slot, ensure=True)
    if not create:
        return None
    # An empty action: give it the one layer and keyframe strip that
    # Blender itself creates when a key is inserted by hand.
    layer = action.layers.new("Layer")
    strip = layer.strips.new(type="KEYFRAME")
    return strip.channelbag(slot, ensure=True)


def fcurves(id_data):
    """The F-curves animating ``id_data`` through its action, or ``[]``."""
    bag = _channelbag(id_data, create=False)
    return bag.fcurves if bag is not None else []


def find_fcurve(id_data, data_path: str, index: int = 0):
    bag = _channelbag(id_data, create=False)
    return bag.fcurves.find(data_path, index=index) if bag is not None else None


def ensure_fcurve(id_data, data_path: str, action_name: str, group: str):
    """The F-curve for ``data_path``, creating an action, a slot and the
    curve as needed.  An action the user already assigned is reused."""
    ad = id_data.animation_data or id_data.animation_data_create()
    if ad.action is None:
        ad.action = bpy.data.actions.new(action_name)
    bag = _channelbag(id_data, create=True)
    fc = bag.fcurves.find(data_path, index=0)
    if fc is None:
        if SLOTTED_ACTIONS:
            fc = bag.fcurves.new(data_path, index=0)
            grp = bag.groups.get(group) or bag.groups.new(group)
            fc.group = grp
        else:
            fc = bag.fcurves.new(data_path, index=0, action_group=group)
    return fc


def remove_fcurve(id_data, fc) -> None:
    bag = _channelbag(id_data, create=False)
    if bag is not None:
        bag.fcurves.remove(fc)


def new_sound_strip(scene, name: str, filepath: str, channel: int, frame_start: int):
    """Add a sound strip (used by tests and the sample scene)."""
    ed = scene.sequence_editor or scene.sequence_editor_create()
    strips = getattr(ed, "strips", None)
    if strips is None:
        strips = ed.sequences
    return strips.new_sound(name, filepath, channel, frame_start)
