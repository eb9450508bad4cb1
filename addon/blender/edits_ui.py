"""The Hand Edits part of the Lip Sync panel and its Bake operator: what
Generate does with an animator's changes to the keys (keep or discard, a
locked range of frames), and the lip sync made plain keys (see
:mod:`.edits`)."""

from __future__ import annotations

import bpy
from bpy.props import StringProperty

from ..engine.errors import LipSyncError
from . import edits, gestures, jobs, keying, run
from .operators import face
from .panel import SidebarPanel


def _targets(obj) -> list:
    """``obj`` and the character's other meshes keyed with it (as Clear takes them)."""
    names = [kb.name for kb in obj.data.shape_keys.key_blocks[1:]] if obj.type == "MESH" and \
        obj.data.shape_keys is not None else []
    also = run.companions(obj, names) if obj.type == "MESH" else []
    return [o for o in [obj] + also if keying.lipsynced(o) or edits.remembered(o)]


class LIPSYNC_OT_bake(bpy.types.Operator):
    """Make the lip sync plain keys, your changes in them: Generate no longer remembers its curves here, \
Clear no longer removes them (for export, or to hand the animation on)"""

    bl_idname = "emotive_lipsync.bake"
    bl_label = "Bake Lip Sync"
    bl_options = {"REGISTER", "UNDO"}

    mesh: StringProperty(name="Mesh", description="Mesh name (empty: the panel's face, else the active object)")

    def execute(self, context):
        try:
            obj = face(context, self.mesh)
            targets = _targets(obj)
            if not targets and not gestures.wrote(obj):
                raise LipSyncError(f"{obj.name!r} has no lip sync made by this add-on to bake")
            lines = sum(edits.bake(o) for o in targets)
            gestures.bake(obj)
        except Exception as exc:  # noqa: BLE001 - reported, never a traceback in the UI
            self.report({"ERROR"}, jobs.failure("Bake", exc).message)
            return {"CANCELLED"}
        self.report({"INFO"}, f"Baked the lip sync of {', '.join(o.name for o in targets or [obj])} into plain keys "
                              f"({lines} line{'s' if lines != 1 else ''} remembered before; Generate will key "
                              "those frames afresh)")
        return {"FINISHED"}


class LIPSYNC_PT_edits(SidebarPanel, bpy.types.Panel):
    bl_label = "Hand Edits"
    bl_parent_id = "LIPSYNC_PT_main"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        st = context.scene.emotive_lipsync
        layout.use_property_split = True
        layout.use_property_decorate = False
        layout.prop(st, "hand_edits", expand=True)
        layout.prop(st, "lock_frames")
        col = layout.column(align=True)
        col.active = st.lock_frames
        col.prop(st, "lock_first")
        col.prop(st, "lock_last")
        try:
            obj = face(context)
        except LipSyncError:
            return
        lines = edits.remembered(obj)
        if lines:
            layout.label(text=f"{obj.name}: {lines} line{'s' if lines != 1 else ''} remembered", icon="INFO")
        row = layout.row()
        row.enabled = bool(lines) or keying.lipsynced(obj)
        row.operator(LIPSYNC_OT_bake.bl_idname, icon="KEYINGSET")


classes = (LIPSYNC_OT_bake, LIPSYNC_PT_edits)
