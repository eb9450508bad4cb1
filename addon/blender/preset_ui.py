"""Emotion presets in the sidebar, the way Blender's own preset menus work:
a menu listing the presets, ``+`` to save the current numbers under a new
name, ``-`` to delete a preset of your own.

Presets are the engine's JSON files, so a preset saved here is usable from
the command line (``--emotion path/to/file.json``) and the other way round.
Your presets live in the extension's user folder
(``bpy.utils.extension_path_user``), never beside the add-on's code.
"""

from __future__ import annotations

import os

import bpy
from bpy.props import BoolProperty, StringProperty

from ..engine import presets
from ..engine.errors import LipSyncError

_PACKAGE = __package__.rpartition(".")[0]


def user_dir(create: bool = True, kind: str = "presets") -> str:
    """The user's folder of ``kind`` (``presets``, ``conventions``)."""
    try:
        return bpy.utils.extension_path_user(_PACKAGE, path=kind, create=create)
    except ValueError:
        # Loaded as a plain add-on (not an extension), e.g. from a script.
        path = bpy.utils.user_resource("SCRIPTS", path=os.path.join(kind, "emotive_lipsync"), create=create)
        return path


def builtin_dir() -> str:
    return str(presets.DATA)


class LIPSYNC_MT_emotion_presets(bpy.types.Menu):
    bl_label = "Emotion Presets"
    bl_idname = "LIPSYNC_MT_emotion_presets"

    def draw(self, _context):
        layout = self.layout
        layout.label(text="Built-in")
        for name in presets.builtin_names():
            layout.operator(LIPSYNC_OT_preset_load.bl_idname, text=bpy.path.display_name(name)).name = name
        folder = user_dir(create=False)
        mine = sorted(f[:-5] for f in os.listdir(folder) if f.endswith(".json")) if os.path.isdir(folder) else []
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
        from .operators import _preset_source

        try:
            preset = presets.load(_preset_source(self.name))
        except LipSyncError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        context.scene.emotive_lipsync.load_preset(preset, self.name)
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
        name = self.name.strip()
        if not name or any(c in name for c in '/\\:*?"<>|'):
            self.report({"ERROR"}, f"{name!r} cannot be a preset name (empty, or holds / \\ : * ? \" < > |)")
            return {"CANCELLED"}
        if name in presets.builtin_names():
            self.report({"ERROR"}, f"{name!r} is a built-in preset; choose another name")
            return {"CANCELLED"}
        path = os.path.join(user_dir(), name + ".json")
        if os.path.exists(path) and not self.overwrite:
            self.report({"ERROR"}, f"a preset named {name!r} exists; tick Overwrite to replace it")
            return {"CANCELLED"}
        try:
            preset = st.preset()
            preset.name = name
            preset.description = f"Saved from the Lip Sync panel (based on {st.emotion})"
            presets.save(preset, path)
        except LipSyncError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        st.emotion = name
        self.report({"INFO"}, f"Saved emotion preset {name!r} to {path}")
        return {"FINISHED"}

    def _remove(self, st):
        name = st.emotion
        path = os.path.join(user_dir(create=False), name + ".json")
        if name in presets.builtin_names() or not os.path.isfile(path):
            self.report({"ERROR"}, f"{name!r} is not one of your presets (built-in presets cannot be deleted)")
            return {"CANCELLED"}
        os.remove(path)
        st.load_preset(presets.load("neutral"), "neutral")
        self.report({"INFO"}, f"Deleted emotion preset {name!r}")
        return {"FINISHED"}


classes = (LIPSYNC_MT_emotion_presets, LIPSYNC_OT_preset_load, LIPSYNC_OT_preset_add)
