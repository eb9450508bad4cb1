"""Operators.  Each is thin: resolve its targets (by name, so scripts and
``blender --background`` drive the same operators users click), turn the
settings into plain values, call :mod:`.run`, report.

Every operator is undoable; errors are reported and cancel the operator
before anything has been written.
"""

from __future__ import annotations

import os

import bpy
from bpy.props import BoolProperty, FloatProperty, IntProperty, StringProperty

from ..engine import mapping as mapping_mod
from ..engine import visemes
from ..engine.errors import LipSyncError
from ..engine.language.text import read_text_file
from . import compat, edits, gestures, jobs, keying, run, sources


def face(context, name: str = ""):
    """The face an operator works on: the object named ``name``, else the
    panel's Face, else the active object; checked to be a mesh with shape
    keys, or an armature with pose assets or properties, the add-on may
    animate (else a :class:`LipSyncError` says what is wrong).  The panel
    calls it to show that message."""
    if name:
        obj = bpy.data.objects.get(name)
        if obj is None:
            raise LipSyncError(f"no object named {name!r}")
    else:
        obj = context.scene.emotive_lipsync.target or context.active_object
    run.check_mesh(obj)
    return obj


def _options(context, emotion: str, coarticulation: str, tolerance: float, hand_edits: str = "",
             lock: str = "", no_gestures: bool = False) -> run.Options:
    """An operator's Emotion, Coarticulation, Tolerance, Hand Edits and Lock
    Frames ("" and -1: the panel's); No Gestures turns the gestures off
    (else the panel's Gestures setting)."""
    return run.options(context.scene, emotion or None, coarticulation or None, tolerance if tolerance >= 0 else None,
                       hand_edits=hand_edits.strip().lower() or None, lock=lock or None,
                       gestures=False if no_gestures else None)


#: The operators' Hand Edits and Lock Frames (see :mod:`.edits`).
_HAND_EDITS = dict(name="Hand Edits", description="keep: lay your changes to the line's last keys on the new "
                                                  "ones; discard: key afresh (empty: the panel's)")
_LOCK = dict(name="Lock Frames", description="FIRST-LAST: frames whose keys Generate leaves as they are "
                                             "(none: no lock; empty: the panel's)")
_NO_GESTURES = dict(name="No Gestures", default=False,
                    description="Key no blinks, gaze or head motion (off: the panel's Gestures setting)")


class _Progress:
    """The window manager's progress indicator (a no-op in the background)."""

    def __init__(self, context, parts: int = 1):
        self.wm = context.window_manager
        self.parts = parts
        self.part = 0
        self.wm.progress_begin(0, 1000)

    def __call__(self, _step, frac):
        self.wm.progress_update(int(1000 * (self.part + frac) / self.parts))

    def end(self):
        self.wm.progress_end()


def _fail(op, exc: Exception) -> set:
    op.report({"ERROR"}, jobs.failure("Lip sync", exc).message)
    return {"CANCELLED"}


class LIPSYNC_OT_generate(jobs.ModalJob, bpy.types.Operator):
    """Lip-sync one sound strip or audio file onto the face mesh's shape keys"""

    bl_idname = "emotive_lipsync.generate"
    bl_label = "Generate Lip Sync"
    bl_options = {"REGISTER", "UNDO"}

    strip: StringProperty(name="Strip", description="Sound strip name (empty: the panel's choice)")
    filepath: StringProperty(name="Audio File", subtype="FILE_PATH",
                             description="Audio file to use instead of a strip")
    frame: IntProperty(name="Start Frame", default=-1, description="Frame an audio file starts on "
                                                                   "(-1: the panel's start frame)")
    mesh: StringProperty(name="Mesh", description="Face mesh name (empty: the panel's face, else the active "
                                                  "object)")
    text: StringProperty(name="Transcript", description="Transcript (empty: the panel's)")
    emotion: StringProperty(name="Emotion", description="Preset name or .json path (empty: the panel's "
                                                        "preset, with its edited numbers)")
    coarticulation: StringProperty(name="Coarticulation", description="dominance or rules (empty: the panel's)")
    tolerance: FloatProperty(name="Tolerance", default=-1.0,
                             description="Key reduction tolerance; 0 keys every frame (-1: the panel's)")
    hand_edits: StringProperty(**_HAND_EDITS)
    lock: StringProperty(**_LOCK)
    no_gestures: BoolProperty(**_NO_GESTURES)

    def _inputs(self, context) -> tuple[sources.LineInputs, run.Options]:
        """The line and how to lip-sync it: the properties, else the panel's settings."""
        if self.frame < -1:
            raise LipSyncError(f"start frame {self.frame} is not allowed: give 0 or later "
                               "(-1: the panel's start frame)")
        st = context.scene.emotive_lipsync
        obj = face(context, self.mesh)
        options = _options(context, self.emotion, self.coarticulation, self.tolerance, self.hand_edits, self.lock,
                           self.no_gestures)
        from_file = self.filepath or (not self.strip and st.source == "FILE")
        line = sources.line_inputs(context.scene, strip=self.strip or st.strip,
                                   audio=(self.filepath or st.audio_file) if from_file else None,
                                   frame=self.frame if self.frame >= 0 else st.start_frame, target=obj,
                                   text=self.text if self.text.strip() else None, typed=st.text,
                                   text_block=st.text_block, strip_properties=False)
        return line, options

    def execute(self, context):
        progress = _Progress(context)
        try:
            summary = run.generate(context.scene, *self._inputs(context), progress)
        except Exception as exc:  # noqa: BLE001 - reported, never a traceback in the UI
            return _fail(self, exc)
        finally:
            progress.end()
        self.report({"INFO"}, summary.message())
        return {"FINISHED"}

    def invoke(self, context, _event):
        """From the panel: the engine runs in the background (progress in the
        status bar, Esc cancels); without a window, as ``execute``."""
        if bpy.app.background or context.window is None:
            return self.execute(context)
        try:
            jobs.ensure_free(jobs.GENERATE)
            job = jobs.lipsync_job(context.scene, *self._inputs(context))
        except Exception as exc:  # noqa: BLE001
            return _fail(self, exc)
        return self.run_modal(context, job)


class LIPSYNC_OT_generate_all(bpy.types.Operator):
    """Lip-sync every sound strip of the sequencer, each onto its own mesh (the strip's lipsync_target \
property, else the mesh its name starts with)"""

    bl_idname = "emotive_lipsync.generate_all"
    bl_label = "Generate for All Strips"
    bl_options = {"REGISTER", "UNDO"}

    mesh: StringProperty(name="Fallback Mesh", description="Mesh for strips that name none (empty: skip them)")
    emotion: StringProperty(name="Emotion", description="Preset name or .json path (empty: the panel's)")
    coarticulation: StringProperty(name="Coarticulation", description="dominance or rules (empty: the panel's)")
    tolerance: FloatProperty(name="Tolerance", default=-1.0, description="Key reduction tolerance "
                                                                         "(-1: the panel's)")
    hand_edits: StringProperty(**_HAND_EDITS)
    lock: StringProperty(**_LOCK)
    no_gestures: BoolProperty(**_NO_GESTURES)

    def execute(self, context):
        scene = context.scene
        strips = compat.sound_strips_in_order(scene)
        if not strips:
            self.report({"ERROR"}, "the sequencer has no sound strips")
            return {"CANCELLED"}
        try:
            options = _options(context, self.emotion, self.coarticulation, self.tolerance, self.hand_edits,
                               self.lock, self.no_gestures)
            fallback = bpy.data.objects.get(self.mesh) if self.mesh else None
            if self.mesh and fallback is None:
                raise LipSyncError(f"no object named {self.mesh!r}")
        except Exception as exc:  # noqa: BLE001
            return _fail(self, exc)
        progress = _Progress(context, len(strips))
        done, problems = [], []
        try:
            for i, strip in enumerate(strips):
                progress.part = i
                try:
                    line = sources.line_inputs(scene, strip=strip, fallback=fallback,
                                               no_target="set its lipsync_target property or name it after "
                                                         "the mesh")
                    done.append(run.generate(scene, line, options, progress))
                except LipSyncError as exc:
                    problems.append(str(exc))
        finally:
            progress.end()
        for p in problems:
            self.report({"WARNING"}, p)
        if not done:
            self.report({"ERROR"}, f"no strip was lip-synced ({len(problems)} problems, listed above)")
            return {"CANCELLED"}
        secs = sum(s.seconds for s in done)
        self.report({"INFO"}, f"Lip sync: {len(done)} of {len(strips)} strips onto "
                              f"{len({s.mesh for s in done})} meshes, {sum(s.keys for s in done)} keys, "
                              f"in {secs:.1f} s")
        return {"FINISHED"}


def _shape_key_names(obj) -> list[str]:
    key = obj.data.shape_keys if obj.type == "MESH" else None
    return [kb.name for kb in key.key_blocks[1:]] if key is not None else []


class LIPSYNC_OT_clear(bpy.types.Operator):
    """Remove the lip-sync keys this add-on wrote on the mesh, with your changes to them; keys you set \
yourself elsewhere stay"""

    bl_idname = "emotive_lipsync.clear"
    bl_label = "Clear Lip Sync"
    bl_options = {"REGISTER", "UNDO"}

    mesh: StringProperty(name="Mesh", description="Mesh name (empty: the panel's face, else the active object)")

    def execute(self, context):
        try:
            obj = face(context, self.mesh)
        except Exception as exc:  # noqa: BLE001
            return _fail(self, exc)
        # The character's other meshes keyed with the face (teeth ...) go too.
        also = run.companions(obj, _shape_key_names(obj)) if obj.type == "MESH" else []
        targets = [o for o in [obj] + also if keying.lipsynced(o)]
        if not targets and not gestures.wrote(obj):
            self.report({"WARNING"}, f"{obj.name!r} has no lip sync made by this add-on")
            return {"CANCELLED"}
        removed = sum(keying.clear(o)["keys"] for o in targets) + gestures.clear(obj)
        for o in targets:   # the curves remembered for hand edits go with the keys
            edits.forget(o)
        self.report({"INFO"}, f"Removed {removed} lip-sync keys from {', '.join(o.name for o in targets or [obj])}")
        return {"FINISHED"}


class LIPSYNC_OT_auto_map(bpy.types.Operator):
    """Map the visemes to the mesh's shape keys by their names, following the naming convention the mesh \
uses (Ready Player Me / Oculus, VRChat, ARKit, VRoid / VRM, Character Creator, Daz, MakeHuman, Preston Blair, \
Rhubarb ...)"""

    bl_idname = "emotive_lipsync.auto_map"
    bl_label = "Auto-Map Shape Keys"
    bl_options = {"REGISTER", "UNDO"}

    mesh: StringProperty(name="Mesh", description="Mesh name (empty: the panel's face, else the active object)")
    viseme_set: StringProperty(name="Viseme Set", description="Built-in set name, to map only to it (empty: the "
                                                              "mesh's setting; 'guess' or 'AUTO': any)")
    convention: StringProperty(name="Convention", description="Naming convention to use, by name (empty: the "
                                                              "one the names follow)")

    def execute(self, context):
        try:
            obj = face(context, self.mesh)
            chosen = "AUTO" if self.viseme_set in ("guess", "AUTO") else (self.viseme_set or None)
            if chosen not in (None, "AUTO") and chosen not in visemes.builtin_names():
                raise LipSyncError(f"{chosen!r} is not a built-in viseme set: {', '.join(visemes.builtin_names())}")
            found = run.detect(obj, viseme_set=chosen, convention=self.convention or None)
            if chosen:   # only once the mapping is found: a failed Auto-Map changes nothing
                obj.emotive_lipsync.viseme_set = chosen
            run.apply(obj, found)
            vset = run.mesh_viseme_set(obj)
        except Exception as exc:  # noqa: BLE001
            return _fail(self, exc)
        missing = mapping_mod.unmapped(vset, found.mapping)
        msg = f"{obj.name}: {found.describe(vset)}"
        bad = False
        try:
            have, lacks = gestures.describe(obj)
            msg += "; gestures: " + "; ".join(have + [f"no {w}" for w in lacks])
        except LipSyncError as exc:      # the mapping stands; the studio's gestures.json is malformed
            bad = True
            msg += f"; gestures: {exc}"
        self.report({"WARNING"} if missing or bad else {"INFO"},
                    msg + (f"; unmapped: {', '.join(missing)}" if missing else ""))
        return {"FINISHED"}


class LIPSYNC_OT_mapping_add(bpy.types.Operator):
    """Add a row to the mapping: one viseme driving one shape key"""

    bl_idname = "emotive_lipsync.mapping_add"
    bl_label = "Add Mapping"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        try:
            obj = face(context, "")
            first = run.mesh_viseme_set(obj).visemes[0]
        except Exception as exc:  # noqa: BLE001
            return _fail(self, exc)
        st = obj.emotive_lipsync
        item = st.mapping.add()
        item.viseme = first
        st.mapping_index = len(st.mapping) - 1
        return {"FINISHED"}


class LIPSYNC_OT_mapping_remove(bpy.types.Operator):
    """Remove the selected row of the mapping"""

    bl_idname = "emotive_lipsync.mapping_remove"
    bl_label = "Remove Mapping"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        try:
            obj = face(context, "")
        except Exception as exc:  # noqa: BLE001
            return _fail(self, exc)
        if not len(obj.emotive_lipsync.mapping):
            return {"CANCELLED"}
        st = obj.emotive_lipsync
        st.mapping.remove(st.mapping_index)
        st.mapping_index = max(0, min(st.mapping_index, len(st.mapping) - 1))
        return {"FINISHED"}


class LIPSYNC_OT_load_transcript(bpy.types.Operator):
    """Load a transcript .txt file into a new text block and use it"""

    bl_idname = "emotive_lipsync.load_transcript"
    bl_label = "Load Transcript File"
    bl_options = {"REGISTER", "UNDO"}

    filepath: StringProperty(subtype="FILE_PATH")
    filter_glob: StringProperty(default="*.txt", options={"HIDDEN"})

    def invoke(self, context, _event):
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def execute(self, context):
        try:
            body, notes = read_text_file(bpy.path.abspath(self.filepath))
        except LipSyncError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        for note in notes:
            self.report({"WARNING"}, note)
        name = os.path.basename(self.filepath)
        block = bpy.data.texts.new(name)
        block.from_string(body)
        context.scene.emotive_lipsync.text_block = block
        return {"FINISHED"}


classes = (LIPSYNC_OT_generate, LIPSYNC_OT_generate_all, LIPSYNC_OT_clear, LIPSYNC_OT_auto_map,
           LIPSYNC_OT_mapping_add, LIPSYNC_OT_mapping_remove, LIPSYNC_OT_load_transcript)
