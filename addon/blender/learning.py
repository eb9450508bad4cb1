""""Learn Preset from This Animation": the mesh's shape-key animation over
its sound strips becomes training data for :mod:`..engine.learn`.

The Blender data is read on the main thread; aligning and fitting run in a
background thread while the operator (invoked from the panel) shows
progress and stays cancellable with Esc.  From scripts, ``execute`` runs the
same work in one go.
"""

from __future__ import annotations

import os
import threading
import time

import bpy
import numpy as np
from bpy.props import FloatProperty, StringProperty

from ..engine import learn, presets
from ..engine.errors import LipSyncError
from ..engine.pipeline import align_audio
from . import compat, run, sources


def _tracks(obj, first: int, n_frames: int, fps: float):
    """Values of the mesh's animated shape keys on each frame from ``first``."""
    key = obj.data.shape_keys
    names, columns = [], []
    frames = first + np.arange(n_frames)
    for fc in compat.fcurves(key):
        if not fc.data_path.startswith('key_blocks["') or not fc.data_path.endswith('"].value'):
            continue
        name = fc.data_path[len('key_blocks["'):-len('"].value')]
        if name == key.key_blocks[0].name or name in names:
            continue
        names.append(name)
        columns.append([fc.evaluate(float(f)) for f in frames])
    if not names:
        raise LipSyncError(f"{obj.name!r} has no shape-key animation to learn from")
    return (frames - first) / fps, np.array(columns).T, names


def collect(scene, obj, strip_names: list[str] | None = None):
    """(clip label, Audio, transcript, times, tracks, channels) per strip."""
    run.check_mesh(obj)
    strips = compat.sound_strips(scene)
    if strip_names:
        chosen = [sources.strip_by_name(scene, n) for n in strip_names]
    else:
        chosen = [s for s in strips if sources.strip_target(s) == obj] or strips
    if len(chosen) < 2:
        raise LipSyncError("learning needs at least two sound strips of the mesh speaking (one is held out to "
                           "check the result)")
    fps = sources.scene_fps(scene)
    out = []
    for s in chosen:
        clip = sources.strip_clip(scene, s)
        text, _where = sources.strip_transcript(s, clip.audio_path)
        n = int(np.floor(clip.audio.duration * fps + 1e-9)) + 1
        times, values, names = _tracks(obj, clip.first_frame, n, fps)
        out.append((s.name, clip.audio, text, times, values, names))
    return out


def work(data, viseme_set: str, emotion: str, name: str, holdout: float, progress=None) -> learn.Learned:
    """Align and fit (no Blender data touched: safe in a thread)."""
    clips = []
    for k, (label, audio, text, times, values, names) in enumerate(data):
        if progress:
            progress("align", k / len(data))
        al = align_audio(audio, text)
        clips.append(learn.TrainingClip(label, audio, al, times, values, names))
    return learn.learn(clips, emotion=emotion, viseme_set=viseme_set, name=name, holdout=holdout,
                       progress=progress)


def summary(result: learn.Learned, path: str) -> tuple[str, str]:
    r = result.report
    lh, bh = r["learned"]["heldout"]["rmse"], r["builtin"]["heldout"]["rmse"]
    msg = (f"Learned preset {r['name']!r} from {len(r['clips']['train'])} clips "
           f"({len(r['clips']['heldout'])} held out): held-out RMSE {lh:.4f}, built-in {r['base_preset']} {bh:.4f}")
    if r["better_than_builtin"]:
        return "INFO", msg + f"; saved to {path}"
    return "WARNING", msg + f": NOT better than the built-in preset (saved anyway to {path})"


class LIPSYNC_OT_learn_preset(bpy.types.Operator):
    """Learn an emotion preset from this mesh's shape-key animation over its sound strips (hand-keyed or \
captured lip sync), and save it as one of your presets"""

    bl_idname = "emotive_lipsync.learn_preset"
    bl_label = "Learn Preset from This Animation"
    bl_options = {"REGISTER", "UNDO"}

    mesh: StringProperty(name="Mesh", description="Animated mesh (empty: the panel's face, else the active object)")
    name: StringProperty(name="Name", default="learned", description="Name of the new preset")
    emotion: StringProperty(name="Start From", default="neutral",
                            description="Built-in preset whose other numbers the learned preset keeps")
    strips: StringProperty(name="Strips", description="Comma-separated strip names (empty: the strips of "
                                                      "this mesh, by the batch naming rule)")
    holdout: FloatProperty(name="Held Out", default=0.2, min=0.05, max=0.5,
                           description="Share of the strips kept aside to check the learned preset")

    def _prepare(self, context):
        from .operators import _mesh

        obj = _mesh(context, self.mesh)
        if self.emotion not in presets.builtin_names():
            raise LipSyncError(f"start from a built-in preset: {', '.join(presets.builtin_names())}")
        name = self.name.strip()
        if not name or name in presets.builtin_names() or any(c in name for c in '/\\:*?"<>|'):
            raise LipSyncError(f"{name!r} cannot be the new preset's name")
        st = obj.emotive_lipsync
        if st.viseme_set == "FILE":
            raise LipSyncError("learning needs one of the built-in viseme sets on the mesh")
        names = [n.strip() for n in self.strips.split(",") if n.strip()]
        return obj, st.viseme_set, collect(context.scene, obj, names)

    def _finish(self, context, result):
        from .preset_ui import user_dir

        path = os.path.join(user_dir(), self.name.strip() + ".json")
        result.save(path)
        context.scene.emotive_lipsync.load_preset(result.preset, self.name.strip())
        level, msg = summary(result, path)
        self.report({level}, msg)
        return {"FINISHED"}

    def execute(self, context):
        try:
            _obj, vset, data = self._prepare(context)
            result = work(data, vset, self.emotion, self.name.strip(), self.holdout)
        except LipSyncError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        return self._finish(context, result)

    def invoke(self, context, _event):
        try:
            _obj, vset, data = self._prepare(context)
        except LipSyncError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        self._state = {"step": "align", "frac": 0.0, "result": None, "error": None, "cancel": False}
        state = self._state

        def progress(step, frac):
            if state["cancel"]:
                raise LipSyncError("cancelled")
            state["step"], state["frac"] = step, frac

        def target():
            try:
                state["result"] = work(data, vset, self.emotion, self.name.strip(), self.holdout, progress)
            except LipSyncError as exc:
                state["error"] = str(exc)
            except Exception as exc:  # noqa: BLE001 - shown to the user, never lost in a thread
                state["error"] = f"{type(exc).__name__}: {exc}"

        self._t0 = time.perf_counter()
        self._thread = threading.Thread(target=target, daemon=True)
        self._thread.start()
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.25, window=context.window)
        wm.progress_begin(0, 1000)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        wm = context.window_manager
        if event.type == "ESC":
            self._state["cancel"] = True
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        share = {"align": 0.3, "prepare": 0.1, "fit": 0.5, "evaluate": 0.1}
        done = {"align": 0.0, "prepare": 0.3, "fit": 0.4, "evaluate": 0.9, "done": 1.0}
        st = self._state
        wm.progress_update(int(1000 * (done.get(st["step"], 0) + share.get(st["step"], 0) * st["frac"])))
        context.workspace.status_text_set(f"Learning preset: {st['step']} {100 * st['frac']:.0f} % "
                                          f"({time.perf_counter() - self._t0:.0f} s; Esc cancels)")
        if self._thread.is_alive():
            return {"RUNNING_MODAL"}
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        context.workspace.status_text_set(None)
        if st["error"]:
            self.report({"ERROR"}, st["error"])
            return {"CANCELLED"}
        return self._finish(context, st["result"])


classes = (LIPSYNC_OT_learn_preset,)
