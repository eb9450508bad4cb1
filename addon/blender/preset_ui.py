"""Emotion presets in the sidebar, the way Blender's own preset menus work:
a menu listing the presets, ``+`` to save the current numbers under a new
name, ``-`` to delete a preset of your own.

Presets are the engine's JSON files, so a preset saved here is usable from
the command line (``--emotion NAME``, or the file's path) and the other way
round.  Your presets live in the extension's user folder (see
:mod:`.userdata`), never beside the add-on's code.  Whatever name or path
an operator is given, a problem is reported in a sentence and nothing is
changed.
"""

from __future__ import annotations

import bpy
from bpy.props import BoolProperty, StringProperty

from ..engine import presets
from ..engine.errors import LipSyncError
from . import userdata

class LIPSYNC_MT_emotion_presets(bpy.types.Menu):
    bl_label = "Emotion Presets"
    bl_idname = "LIPSYNC_MT_emotion_presets"

    def draw(self, _context):
        layout = self.layout
        layout.label(text="Built-in")
        for name in presets.builtin_names():
            layout.operator(LIPSYNC_OT_preset_load.bl_idname, text=bpy.path.display_name(name)).name = name
        mine = userdata.preset_names()
        if mine:
            layout.separator()
            layout.label(text="Yours")
            for name in mine:
                layout.operator(LIPSYNC_OT_preset_load.bl_idname, text=name).name = name


class LIPSYNC_OT_preset_load(bpy.types.Operator):
    """Load an emotion preset's numbers into the panel"""

    bl_idname = "emotive_lipsync.preset_load"
    bl_label = "Load Emotion Preset"
    bl_options = {"REGISTER", "UNDO"}

    name: StringProperty(name="Preset", description="Built-in or saved preset name, or a .json path")

    def execute(self, context):
        try:
            preset = userdata.load_preset(self.name)
        except LipSyncError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        context.scene.emotive_lipsync.load_preset(preset, self.name.strip())
        return {"FINISHED"}


class LIPSYNC_OT_preset_add(bpy.types.Operator):
    """Save the panel's emotion numbers as a preset of your own, or delete the current one"""

    bl_idname = "emotive_lipsync.preset_add"
    bl_label = "Add Emotion Preset"
    bl_options = {"REGISTER", "UNDO"}

    name: StringProperty(name="Name", description="Name of the new preset")
    remove_active: BoolProperty(default=False, options={"HIDDEN", "SKIP_SAVE"})
    overwrite: BoolProperty(name="Overwrite", default=False, description="Replace a saved preset of this name")

    def invoke(self, context, _event):
        if self.remove_active:
            return self.execute(context)
        self.name = context.scene.emotive_lipsync.emotion + " copy"
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        st = context.scene.emotive_lipsync
        if self.remove_active:
            return self._remove(st)
        try:
            name = userdata.check_name(self.name)
            preset = userdata.panel_preset(st)
            preset.name = name
            preset.description = f"Saved from the Lip Sync panel (based on {st.emotion})"
            path = userdata.save_preset(preset, name, self.overwrite)
        except LipSyncError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        st.emotion = name
        self.report({"INFO"}, f"Saved emotion preset {name!r} to {path}")
        return {"FINISHED"}

    def _remove(self, st):
        try:
            userdata.remove_preset(st.emotion)
        except LipSyncError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        deleted = st.emotion
        st.load_preset(presets.load("neutral"), "neutral")
        self.report({"INFO"}, f"Deleted emotion preset {deleted!r}")
        return {"FINISHED"}


classes = (LIPSYNC_MT_emotion_presets, LIPSYNC_OT_preset_load, LIPSYNC_OT_preset_add)
