"""The "Lip Sync" tab of the 3D View sidebar.  Drawing only: what is missing
is shown before Generate is pressed, computed from the data, never changed."""

from __future__ import annotations

import os

import bpy

from ..engine import conventions
from ..engine import mapping as mapping_mod
from ..engine import visemes
from ..engine.errors import LipSyncError
from ..engine.language import resolve_language
from . import compat, keying, run, sources
from .emotion_markers import STRIP_AROUSAL
from .operators import (LIPSYNC_OT_auto_map, LIPSYNC_OT_clear, LIPSYNC_OT_generate, LIPSYNC_OT_generate_all,
                        LIPSYNC_OT_load_transcript, LIPSYNC_OT_mapping_add, LIPSYNC_OT_mapping_remove, face)
from .preset_ui import LIPSYNC_MT_emotion_presets, LIPSYNC_OT_preset_add


def _face(context):
    """(the face mesh, None), or (None, why there is none to animate): the
    operators' :func:`.operators.face`, its error shown instead of raised."""
    try:
        return face(context), None
    except LipSyncError as exc:
        why = str(exc)
        return None, why[:1].upper() + why[1:]


_detect_cache: dict = {}


def _detected(obj):
    """The convention Generate would pick for ``obj`` (kept while its shape
    keys and settings stay the same: the panel redraws often)."""
    st = obj.emotive_lipsync
    sig = (obj.name, tuple(run.check_mesh(obj)), st.viseme_set, st.viseme_set_file)
    if sig not in _detect_cache:
        if len(_detect_cache) > 64:
            _detect_cache.clear()
        try:
            _detect_cache[sig] = run.detect(obj)
        except LipSyncError as exc:
            _detect_cache[sig] = exc
    found = _detect_cache[sig]
    if isinstance(found, LipSyncError):
        raise found
    return found


def units_without_key(obj) -> list[str]:
    """The FACS action units no shape key of ``obj`` shows, as a run finds
    them (:func:`.run.plan`; its report names those a preset sets); kept
    like :func:`_detected`.  An armature shows none: the expression layer
    drives shape keys only."""
    try:
        names = run.check_mesh(obj) if obj.type == "MESH" else []
    except LipSyncError:        # nothing to animate: the panel says why elsewhere
        return []
    sig = ("units", obj.name, tuple(names), obj.emotive_lipsync.convention)
    if sig not in _detect_cache:
        if len(_detect_cache) > 64:
            _detect_cache.clear()
        _detect_cache[sig] = conventions.expression_match(names, run.all_conventions(), (obj.name, obj.data.name),
                                                          prefer=obj.emotive_lipsync.convention).missing
    return _detect_cache[sig]


def _convention_text(obj) -> str:
    """The naming convention the face's keys follow, for the panel."""
    ost = obj.emotive_lipsync
    if len(ost.mapping):
        return ost.convention or "Mapped by hand"
    if obj.type == "MESH" and (obj.data.shape_keys is None or len(obj.data.shape_keys.key_blocks) < 2):
        return ""
    try:
        return _detected(obj).convention.label + " (detected)"
    except LipSyncError:
        return ""


def problems(context) -> list[str]:
    """What stops Generate from working, in words an animator reads."""
    return checklist(context)[0]


def checklist(context) -> tuple[list[str], str]:
    """(:func:`problems`, a note on where Generate will read the words from
    when that is not a transcript, or ""), the audio's path found once."""
    st = context.scene.emotive_lipsync
    out = []
    obj, why = _face(context)
    if obj is None:
        out.append(why)
    else:
        ost = obj.emotive_lipsync
        try:
            if ost.mapping_dict():
                missing = mapping_mod.unmapped(run.mesh_viseme_set(obj), ost.mapping_dict())
            else:
                try:
                    found = _detected(obj)
                except LipSyncError:
                    found = None
                    out.append(f"The {run.driven_words(obj)} of {obj.name} follow no known naming convention: "
                               "map them below, "
                               "or pick their viseme set")
                missing = mapping_mod.unmapped(visemes.load(found.convention.viseme_set), found.mapping) \
                    if found is not None else []
            if missing:
                out.append(f"Unmapped visemes: {', '.join(missing)}")
        except LipSyncError as exc:
            out.append(str(exc))
    audio_path = _audio(context, out)
    has_text = _has_text(st, audio_path)
    if st.text_block is not None and not st.text_block.as_string().strip():
        out.append(f"Text block {st.text_block.name} is empty")
    elif not has_text and st.language.strip():
        try:
            lang = resolve_language(st.language)
        except LipSyncError as exc:
            out.append(str(exc).split(";")[0])
        else:
            if not lang.is_english:
                out.append(f"No transcript: a line in {lang.name} needs one (speech is recognised in English "
                           "only)")
    return out, ("" if out or has_text else NO_TRANSCRIPT)


def _audio(context, out: list[str] | None = None) -> str | None:
    """The path of the audio Generate would read (None for packed sound);
    what is wrong with the choice goes into ``out``."""
    st = context.scene.emotive_lipsync
    out = [] if out is None else out
    if st.source == "FILE":
        if not st.audio_file:
            out.append("No audio file")
            return None
        path = bpy.path.abspath(st.audio_file)
        if not os.path.isfile(path):
            out.append(f"Audio file not found: {st.audio_file}")
        return path
    if st.strip:
        strip = next((s for s in compat.sound_strips(context.scene) if s.name == st.strip), None)
        if strip is None:
            out.append(f"No sound strip named {st.strip}")
    else:
        strip = sources.active_sound_strip(context.scene)
        if strip is None:
            out.append("No sound strip: add one, or pick an audio file")
    if strip is not None and strip.sound is not None and strip.sound.packed_file is None:
        return sources.sound_path(strip.sound)
    return None


def _has_text(st, audio_path: str | None) -> bool:
    return bool((st.text_block is not None and st.text_block.as_string().strip()) or st.text.strip() or
                (audio_path and sources.has_sidecar_transcript(audio_path)))


NO_TRANSCRIPT = "No transcript: the words will be recognised from the audio"


class LIPSYNC_UL_mapping(bpy.types.UIList):
    def draw_item(self, _context, layout, data, item, _icon, _active_data, _active_propname, _index=0):
        obj = data.id_data
        row = layout.row(align=True)
        row.label(text=item.viseme)
        key = obj.data.shape_keys if obj.type == "MESH" else None
        if key is not None:
            row.prop_search(item, "shape_key", key, "key_blocks", text="")
        else:
            row.prop(item, "shape_key", text="")
        row.prop(item, "weight", text="")


class SidebarPanel:
    """Where every Lip Sync panel sits: the 3D View's sidebar, its Lip Sync tab."""

    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Lip Sync"



class LIPSYNC_PT_main(SidebarPanel, bpy.types.Panel):
    bl_label = "Lip Sync"

    def draw(self, context):
        layout = self.layout
        st = context.scene.emotive_lipsync
        layout.use_property_split = True
        layout.use_property_decorate = False

        col = layout.column()
        col.prop(st, "source", expand=True)
        if st.source == "STRIP":
            ed = context.scene.sequence_editor
            if ed is not None:
                col.prop_search(st, "strip", ed, compat.ALL_STRIPS_PROPERTY, text="Strip")
                strip = next((s for s in compat.sound_strips(context.scene) if s.name == st.strip), None) \
                    if st.strip else sources.active_sound_strip(context.scene)
                if strip is not None and STRIP_AROUSAL in strip:
                    col.label(text=f"Voice arousal: {strip[STRIP_AROUSAL]:+.2f} (calm -1, excited +1)",
                              icon="SOUND")
            else:
                col.label(text="The sequencer is empty", icon="INFO")
        else:
            col.prop(st, "audio_file")
            col.prop(st, "start_frame")

        col = layout.column(heading="Transcript")
        col.prop(st, "text_block")
        if st.text_block is None:
            col.prop(st, "text", text="Text")
            col.operator(LIPSYNC_OT_load_transcript.bl_idname, icon="FILE_TEXT", text="Load .txt")
        col.prop(st, "language")

        layout.prop(st, "target")
        obj, _why = _face(context)
        convention = _convention_text(obj) if obj is not None else ""
        if convention:
            row = layout.row()
            row.alignment = "RIGHT"
            row.label(text=convention, icon="SHAPEKEY_DATA")

        issues, note = checklist(context)
        box = layout.box() if issues else None
        for msg in issues:
            box.label(text=msg, icon="ERROR")
        if note:
            layout.label(text=note, icon="INFO")
        row = layout.row()
        row.scale_y = 1.6
        row.enabled = not issues
        row.operator(LIPSYNC_OT_generate.bl_idname, icon="PLAY_SOUND")
        row = layout.row(align=True)
        row.operator(LIPSYNC_OT_generate_all.bl_idname, icon="SEQUENCE")
        sub = row.row(align=True)
        sub.enabled = obj is not None and keying.lipsynced(obj)
        sub.operator(LIPSYNC_OT_clear.bl_idname, icon="X", text="Clear")


class LIPSYNC_PT_shapes(SidebarPanel, bpy.types.Panel):
    bl_label = "Visemes and Shape Keys"
    bl_parent_id = "LIPSYNC_PT_main"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        obj, why = _face(context)
        if obj is None:
            layout.label(text=why, icon="ERROR")
            return
        ost = obj.emotive_lipsync
        layout.use_property_split = True
        layout.prop(ost, "viseme_set")
        if ost.viseme_set == "FILE":
            layout.prop(ost, "viseme_set_file")
        if len(ost.mapping) and ost.convention:
            layout.label(text=f"Convention: {ost.convention}", icon="CHECKMARK")
        elif not len(ost.mapping) and (obj.type == "ARMATURE" or obj.data.shape_keys is not None):
            try:
                found = _detected(obj)
                layout.label(text=f"Detected: {found.describe(visemes.load(found.convention.viseme_set))}",
                             icon="VIEWZOOM")
            except LipSyncError:
                layout.label(text="No known naming convention: map by hand", icon="ERROR")
        layout.operator(LIPSYNC_OT_auto_map.bl_idname, icon="AUTO")
        row = layout.row()
        row.template_list("LIPSYNC_UL_mapping", "", ost, "mapping", ost, "mapping_index", rows=6)
        col = row.column(align=True)
        col.operator(LIPSYNC_OT_mapping_add.bl_idname, icon="ADD", text="")
        col.operator(LIPSYNC_OT_mapping_remove.bl_idname, icon="REMOVE", text="")
        if not len(ost.mapping):
            layout.label(text="Empty: Generate maps by name automatically", icon="INFO")


class LIPSYNC_PT_emotion(SidebarPanel, bpy.types.Panel):
    bl_label = "Emotion and Motion"
    bl_parent_id = "LIPSYNC_PT_main"

    def draw(self, context):
        layout = self.layout
        st = context.scene.emotive_lipsync
        row = layout.row(align=True)
        row.menu(LIPSYNC_MT_emotion_presets.bl_idname, text=bpy.path.display_name(st.emotion) or "Preset")
        row.operator(LIPSYNC_OT_preset_add.bl_idname, text="", icon="ADD")
        row.operator(LIPSYNC_OT_preset_add.bl_idname, text="", icon="REMOVE").remove_active = True
        layout.use_property_split = True
        layout.prop(st, "coarticulation")
        layout.prop(st, "emotion_fade")
        col = layout.column(heading="Keys")
        col.prop(st, "whole_character")
        col.prop(st, "reduce_keys")
        sub = col.column()
        sub.active = st.reduce_keys
        sub.prop(st, "tolerance")
        layout.prop(st, "dictionary")
        layout.operator("emotive_lipsync.learn_preset", icon="EXPERIMENTAL")
        layout.use_property_split = False
        layout.prop(st, "show_preset_values", icon="TRIA_DOWN" if st.show_preset_values else "TRIA_RIGHT",
                    emboss=False)
        if st.show_preset_values:
            if not len(st.preset_values):
                layout.label(text="Pick a preset to edit its numbers")
            box = layout.box().column(align=True)
            obj, _why = _face(context)
            missing = set(units_without_key(obj)) if obj is not None else set()
            for item in st.preset_values:
                row = box.row(align=True)
                unit = item.path.split(".", 1)[1] if item.path.startswith("expression.") else None
                if unit in missing:   # the preset sets it, the face cannot show it
                    row.label(text=f"{item.path}: no key on {obj.name}", icon="ERROR")
                else:
                    row.label(text=item.path)
                prop = {"NUMBER": "number", "TRIPLE": "triple"}.get(item.kind, "text")
                row.prop(item, prop, text="")


classes = (LIPSYNC_UL_mapping, LIPSYNC_PT_main, LIPSYNC_PT_shapes, LIPSYNC_PT_emotion)
