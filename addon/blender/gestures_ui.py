"""The Gestures part of the Lip Sync panel: blinks, gaze, head and neck
motion on or off, the seed that varies them, and which of them the face
can show (the channels found, and what it lacks: listed, never an error).
The numbers of the motion are the emotion preset's (its ``gestures``
section, under Preset Numbers)."""

from __future__ import annotations

import bpy

from ..engine.errors import LipSyncError
from . import gestures
from .operators import face
from .panel import SidebarPanel


class LIPSYNC_PT_gestures(SidebarPanel, bpy.types.Panel):
    bl_label = "Gestures"
    bl_parent_id = "LIPSYNC_PT_main"
    bl_options = {"DEFAULT_CLOSED"}

    def draw_header(self, context):
        self.layout.prop(context.scene.emotive_lipsync, "gestures", text="")

    def draw(self, context):
        layout = self.layout
        st = context.scene.emotive_lipsync
        layout.use_property_split = True
        layout.use_property_decorate = False
        layout.active = st.gestures
        layout.prop(st, "gesture_seed")
        try:
            obj = face(context)
        except LipSyncError:
            return
        try:
            have, missing = gestures.describe(obj)
        except LipSyncError as exc:      # the studio's gestures.json, malformed
            layout.label(text=str(exc), icon="ERROR")
            return
        col = layout.column(align=True)
        for line in have:
            col.label(text=line, icon="CHECKMARK")
        for what in missing:
            col.label(text=f"No {what}", icon="INFO")


classes = (LIPSYNC_PT_gestures,)
