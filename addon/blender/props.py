"""Settings stored in the .blend: per scene (what to lip-sync, and how) and
per object (which viseme set the mesh follows and which shape keys show
each viseme)."""

from __future__ import annotations

import json

import bpy
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty, FloatVectorProperty,
                       IntProperty, PointerProperty, StringProperty)

from ..engine import presets, visemes
from ..engine.emotion_track import DEFAULT_FADE

# Stored as numbers: the sets of the first release keep theirs, so older
# files read back the same choice; later sets are numbered from 10 up.
_NUMBERS = {"arkit": 0, "default": 1, "oculus": 2, "preston_blair": 3, "rhubarb": 4, "FILE": 5, "AUTO": 99}


def _set_items():
    names = visemes.builtin_names()
    later = {n: 10 + i for i, n in enumerate(n for n in names if n not in _NUMBERS)}
    return ([("AUTO", "Automatic", "Follow the naming convention of the mesh's shape keys (Ready Player Me, ARKit, "
              "VRoid, Character Creator, Daz ...)", _NUMBERS["AUTO"])]
            + [(n, {"arkit": "ARKit"}.get(n, n.replace("_", " ").title()), visemes.load(n).description,
                _NUMBERS.get(n, later.get(n))) for n in names]
            + [("FILE", "From File", "A viseme set of your own (JSON file)", _NUMBERS["FILE"])])


VISEME_SETS = _set_items()


#: A mesh's settings may be changed on a library override of it (Generate
#: fills the mapping in), as on a local mesh.
_OV = {"LIBRARY_OVERRIDABLE"}


def _drivable(self, _context, _edit_text):
    """What a mapping row may name: the mesh's shape keys, the armature's
    pose assets and number properties (the text field's search list)."""
    obj = self.id_data
    if obj.type == "ARMATURE":
        from . import rig

        return rig.names(obj)[1:]
    key = obj.data.shape_keys if obj.type == "MESH" else None
    return [kb.name for kb in key.key_blocks[1:]] if key is not None else []


class LIPSYNC_PG_mapping_item(bpy.types.PropertyGroup):
    """One viseme driving one shape key (on an armature: a pose asset or a
    property) with a weight."""

    viseme: StringProperty(override=_OV, name="Viseme", description="Viseme of the mesh's viseme set")
    shape_key: StringProperty(override=_OV, name="Shape Key", search=_drivable,
                              description="Shape key this viseme drives (on an armature: a pose asset or a "
                                          "custom property, bone:property for a pose bone's)")
    weight: FloatProperty(name="Weight", description="How much of the viseme's curve goes into the shape key",
                          default=1.0, min=0.0, soft_max=1.0, max=2.0, override=_OV)


class LIPSYNC_PG_object(bpy.types.PropertyGroup):
    viseme_set: EnumProperty(override=_OV, name="Viseme Set", items=VISEME_SETS, default="AUTO",
                             description="The mouth shapes this mesh's shape keys follow")
    convention: StringProperty(override=_OV, name="Convention",
                               description="The naming convention the mapping was made from (filled in by "
                                           "Auto-Map)")
    mapped_set: StringProperty(override=_OV, name="Mapped Set", options={"HIDDEN"},
                               description="The viseme set the mapping was made for")
    closure_rule: StringProperty(override=_OV, name="Closure", options={"HIDDEN"},
                                 description="How this mesh's keys close the lips on /p b m/ (JSON, from the "
                                             "convention)")
    viseme_set_file: StringProperty(override=_OV, name="Viseme Set File", subtype="FILE_PATH",
                                    description="A viseme set JSON file (see docs/presets.md)")
    mapping: CollectionProperty(type=LIPSYNC_PG_mapping_item, override={"LIBRARY_OVERRIDABLE", "USE_INSERTION"})
    mapping_index: IntProperty(override=_OV, name="Active Mapping", default=0)

    def viseme_set_source(self) -> str | None:
        """The chosen set's name or file; None for Automatic."""
        if self.viseme_set == "FILE":
            return bpy.path.abspath(self.viseme_set_file)
        return None if self.viseme_set == "AUTO" else self.viseme_set

    def mapping_dict(self) -> dict[str, dict[str, float]]:
        """Viseme -> {shape key: weight}; a row with no shape key says the
        basis shape shows that viseme."""
        out: dict[str, dict[str, float]] = {}
        for item in self.mapping:
            if item.viseme:
                mix = out.setdefault(item.viseme, {})
                if item.shape_key:
                    mix[item.shape_key] = item.weight
        return out

    def set_mapping(self, mapping: dict[str, dict[str, float]]) -> None:
        self.mapping.clear()
        for v, mix in mapping.items():
            for k, w in (mix or {"": 1.0}).items():
                item = self.mapping.add()
                item.viseme, item.shape_key, item.weight = v, k, w
        self.mapping_index = 0


class LIPSYNC_PG_preset_value(bpy.types.PropertyGroup):
    """One number (or triple, or word list) of an emotion preset."""

    path: StringProperty(name="Field")
    kind: EnumProperty(items=[("NUMBER", "Number", ""), ("TRIPLE", "Triple", ""), ("TEXT", "Text", ""),
                              ("LIST", "List", "")], default="NUMBER")
    number: FloatProperty(name="Value", precision=3)
    triple: FloatVectorProperty(name="Value", size=3, precision=3)
    text: StringProperty(name="Value")

    def value(self):
        if self.kind == "NUMBER":
            return float(self.number)
        if self.kind == "TRIPLE":
            return [float(x) for x in self.triple]
        if self.kind == "LIST":
            return [_number_or_word(t) for t in self.text.split()]
        return self.text


def _number_or_word(token: str):
    try:
        return float(token)
    except ValueError:
        return token


def _target_poll(_self, obj):
    return obj.type in ("MESH", "ARMATURE")


class LIPSYNC_PG_scene(bpy.types.PropertyGroup):
    source: EnumProperty(name="Audio", default="STRIP", items=[
        ("STRIP", "Sound Strip", "A sound strip of this scene's sequencer"),
        ("FILE", "Audio File", "An audio file on disk"),
    ])
    strip: StringProperty(name="Strip", description="Sound strip to lip-sync (empty: the active sound strip)")
    audio_file: StringProperty(name="File", subtype="FILE_PATH", description="Audio file to lip-sync")
    start_frame: IntProperty(name="Start Frame", default=1, description="Frame the audio file starts on")
    text: StringProperty(name="Transcript", description="What is said (a text block, or NAME.txt beside the "
                                                         "audio, is used when this is empty)")
    text_block: PointerProperty(name="Text Block", type=bpy.types.Text,
                                description="A text block holding the transcript")
    language: StringProperty(name="Language", default="",
                             description="Language of the transcript: an ISO 639-1 or 639-3 code or a BCP-47 tag "
                                         "(de, deu, pt-BR, zh, ja ...); empty: English")
    target: PointerProperty(name="Face", type=bpy.types.Object, poll=_target_poll,
                            description="Mesh whose shape keys, or armature whose pose assets and properties, "
                                        "are animated (empty: the active object)")
    emotion: StringProperty(name="Emotion", default="neutral",
                            description="Emotion preset the numbers below were loaded from")
    preset_values: CollectionProperty(type=LIPSYNC_PG_preset_value)
    learned: StringProperty(name="Learned Poses", options={"HIDDEN"},
                            description="A learned preset's poses (JSON): kept whole, as shape-key names may hold "
                                        "dots")
    show_preset_values: BoolProperty(name="Preset Numbers", default=False)
    coarticulation: EnumProperty(name="Coarticulation", default="dominance", items=[
        ("dominance", "Dominance", "Cohen-Massaro dominance functions: smooth blending, tunable per "
                                   "phoneme class"),
        ("rules", "Rules", "Anticipation and carry-over rules per vowel/consonant context"),
    ])
    whole_character: BoolProperty(name="Whole Character", default=True,
                                  description="Also key the character's other meshes (teeth, tongue, beard) that "
                                              "have the same shape keys and share the face's armature or parent")
    reduce_keys: BoolProperty(name="Reduce Keys", default=False,
                              description="Keep only the keys needed to stay within the tolerance")
    tolerance: FloatProperty(name="Tolerance", default=0.02, min=0.001, max=0.5, precision=3,
                             description="Largest change in a shape key's value that dropping keys may cause")
    emotion_fade: FloatProperty(name="Emotion Fade", default=DEFAULT_FADE, min=0.0, max=2.0, unit="TIME_ABSOLUTE",
                                description="Seconds over which an emotion change (an [angry] tag in the "
                                            "transcript, an emotion:angry timeline marker) cross-fades")
    dictionary: StringProperty(name="Dictionary", subtype="FILE_PATH",
                               description="Your own pronunciations: lines of WORD PH1 PH2 ... (ARPAbet)")
    hand_edits: EnumProperty(name="Hand Edits", default="KEEP", items=[
        ("KEEP", "Keep", "Lay your changes to the keys of the line's last Generate on the new curves, moved with "
                         "their sound"),
        ("DISCARD", "Discard", "Key the new curves as they come: your changes to the last Generate's keys go"),
    ])
    lock_frames: BoolProperty(name="Lock Frames", default=False,
                              description="Leave the keys of these frames exactly as they are when Generating")
    gestures: BoolProperty(name="Gestures", default=True,
                           description="Blinks, gaze, head and neck motion and brow raises that follow the speech "
                                       "(their numbers are the emotion preset's)")
    gesture_seed: IntProperty(name="Seed", default=0, min=0,
                              description="Another seed gives the same line other blinks, glances and head motion")
    lock_first: IntProperty(name="First", default=1, description="First locked frame")
    lock_last: IntProperty(name="Last", default=1, description="Last locked frame")

    def load_preset(self, preset: presets.Preset | dict, name: str) -> None:
        doc = preset.to_dict() if isinstance(preset, presets.Preset) else preset
        self.preset_values.clear()
        self.learned = json.dumps(doc["learned"]) if "learned" in doc else ""
        for path, value in presets.to_flat({k: v for k, v in doc.items() if k != "learned"}).items():
            if path in ("name", "description"):
                continue
            item = self.preset_values.add()
            item.path = path
            if isinstance(value, bool) or not isinstance(value, (int, float, list, str)):
                item.kind, item.text = "TEXT", str(value)
            elif isinstance(value, (int, float)):
                item.kind, item.number = "NUMBER", float(value)
            elif isinstance(value, list) and len(value) == 3 and all(isinstance(x, (int, float)) for x in value):
                item.kind, item.triple = "TRIPLE", value
            elif isinstance(value, list):
                item.kind, item.text = "LIST", " ".join(str(x) for x in value)
            else:
                item.kind, item.text = "TEXT", value
        self.emotion = name


classes = (LIPSYNC_PG_mapping_item, LIPSYNC_PG_object, LIPSYNC_PG_preset_value, LIPSYNC_PG_scene)


def register():
    for c in classes:
        bpy.utils.register_class(c)
    bpy.types.Scene.emotive_lipsync = PointerProperty(type=LIPSYNC_PG_scene)
    bpy.types.Object.emotive_lipsync = PointerProperty(type=LIPSYNC_PG_object, override=_OV)


def unregister():
    del bpy.types.Object.emotive_lipsync
    del bpy.types.Scene.emotive_lipsync
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
