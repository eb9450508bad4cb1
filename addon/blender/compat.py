"""Every difference between the Blender versions (and builds) the extension
supports, 4.2 LTS to 5.2 LTS.  The rest of the extension calls these
functions and never tests a version itself.

* Animation data: Blender 4.2-4.3 keep F-curves on ``Action.fcurves``.
  4.4 introduced slotted actions, where F-curves live in a channelbag per
  slot and layer; ``Action.fcurves`` still worked there for the first slot
  and was removed in 5.0.
  https://developer.blender.org/docs/release_notes/4.4/python_api/#slotted-actions
  https://developer.blender.org/docs/release_notes/5.0/python_api/
* Sequencer: ``SequenceEditor.sequences_all`` became ``strips_all`` in 4.4
  (``sequences_all`` was removed in 5.0).
  https://developer.blender.org/docs/release_notes/4.4/sequencer/
* Strip timing: 5.1 renamed a strip's frame properties (``frame_start`` ->
  ``content_start``, ``frame_final_start``/``frame_final_end`` ->
  ``left_handle``/``right_handle``); the old names still work there but
  raise a DeprecationWarning saying they go in 6.0.  A sound strip's
  ``sound_offset`` (seconds) does not exist in 4.2.
* Audio: Blender decodes sound with its own library, Audaspace (the ``aud``
  module).  The ``bpy`` module on PyPI for 4.2 is built without it: no
  ``aud``, and sound strips cannot be added there (those read from a .blend
  keep their timing).  Audio is then decoded by the engine's own reader
  (Praat, through parselmouth).
"""

from __future__ import annotations

import bpy
import numpy as np

from ..engine.audio import Audio, from_samples, load
from ..engine.errors import AudioError

SLOTTED_ACTIONS = bpy.app.version >= (4, 4, 0)

#: Strip handles named ``left_handle``/``right_handle`` (5.1 and later).
STRIP_HANDLES = bpy.app.version >= (5, 1, 0)

#: Blender's sound library is built in (everywhere but PyPI's 4.2 ``bpy``).
AUDASPACE = bool(bpy.app.build_options.audaspace)


# --- audio ---------------------------------------------------------------------

def decode_file(path: str) -> Audio:
    """An existing audio file -> the engine's mono samples.

    With Audaspace every format the sequencer plays is read (WAV, FLAC, MP3,
    OGG, AAC ...); without it the engine's reader takes WAV, FLAC, MP3 and
    AIFF.  Raises :class:`AudioError` or, from Audaspace, its own error
    types (the caller reports those)."""
    if not AUDASPACE:
        return load(path)
    import aud  # only in a Blender built with Audaspace

    snd = aud.Sound(path)
    rate = int(snd.specs[0])
    data = snd.rechannel(1).data()
    if data is None or data.size == 0 or rate <= 0:
        raise AudioError(f"{path} holds no audio")
    return from_samples(np.asarray(data[:, 0], dtype=np.float32), rate)


# --- sequencer ---------------------------------------------------------------

def all_strips(scene):
    ed = scene.sequence_editor
    if ed is None:
        return []
    strips = getattr(ed, "strips_all", None)
    return list(strips if strips is not None else ed.sequences_all)


def sound_strips(scene):
    return [s for s in all_strips(scene) if s.type == "SOUND"]


def sound_strips_in_order(scene):
    """Every sound strip, earliest first (then by channel)."""
    return sorted(sound_strips(scene), key=lambda s: (strip_frames(s)[0], s.channel))


#: The ``SequenceEditor`` collection of every strip, by name (for ``prop_search``).
ALL_STRIPS_PROPERTY = "strips_all" if "strips_all" in bpy.types.SequenceEditor.bl_rna.properties \
    else "sequences_all"


def strip_frames(strip) -> tuple[int, int]:
    """The strip's first visible frame and the first frame after it."""
    if STRIP_HANDLES:
        return strip.left_handle, strip.right_handle
    return strip.frame_final_start, strip.frame_final_end


def trim_strip_start(strip, frame: int) -> None:
    """Hide the strip's sound before ``frame`` (as dragging its left handle does)."""
    if STRIP_HANDLES:
        strip.left_handle = frame
    else:
        strip.frame_final_start = frame


def strip_content_start(strip) -> float:
    """The frame the strip's sound starts on (before any trim)."""
    return strip.content_start if STRIP_HANDLES else strip.frame_start


def strip_sound_offset(strip) -> float:
    """Seconds of the sound skipped before the strip's content start (no
    such property in 4.2: 0 there)."""
    return getattr(strip, "sound_offset", 0.0)


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


def ensure_fcurve(id_data, data_path: str, action_name: str, group: str, index: int = 0):
    """The F-curve for ``data_path`` (component ``index``), creating an
    action, a slot and the curve as needed.  An action the user already
    assigned is reused."""
    ad = id_data.animation_data or id_data.animation_data_create()
    if ad.action is None:
        ad.action = bpy.data.actions.new(action_name)
    bag = _channelbag(id_data, create=True)
    fc = bag.fcurves.find(data_path, index=index)
    if fc is None:
        if SLOTTED_ACTIONS:
            fc = bag.fcurves.new(data_path, index=index)
            grp = bag.groups.get(group) or bag.groups.new(group)
            fc.group = grp
        else:
            fc = bag.fcurves.new(data_path, index=index, action_group=group)
    return fc


def action_fcurves(action) -> list:
    """Every F-curve an action holds (a pose asset's channels), whatever its
    slots and layers."""
    if not SLOTTED_ACTIONS:
        return list(action.fcurves)
    out = []
    for layer in action.layers:
        for strip in layer.strips:
            for bag in strip.channelbags:
                out.extend(bag.fcurves)
    return out


def fcurves_of(id_data) -> list:
    """The F-curves of the action animating ``id_data`` (its slot's, on a slotted action)."""
    bag = _channelbag(id_data, create=False)
    return list(bag.fcurves) if bag is not None else []


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
