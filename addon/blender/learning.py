""""Learn Preset from This Animation": the mesh's shape-key animation over
its sound strips becomes training data for :mod:`..engine.learning`.

The Blender data is read on the main thread; aligning and fitting are a
:class:`.jobs.Job`, run in a background thread when the operator is invoked
from the panel (progress in the status bar, Esc cancels) and in one go from
scripts.
"""

from __future__ import annotations

import os

import bpy
import numpy as np
from bpy.props import BoolProperty, FloatProperty, StringProperty

from ..engine import learning, presets
from ..engine.errors import LipSyncError
from ..engine.alignment import align_audio
from . import compat, jobs, run, sources, userdata
from .operators import face


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
    if obj.type != "MESH":
        raise LipSyncError(f"{obj.name!r} is an armature: learning reads a mesh's shape-key animation")
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
        text, _where = sources.strip_transcript(s, clip.audio_path, required=True)
        n = int(np.floor(clip.audio.duration * fps + 1e-9)) + 1
        times, values, names = _tracks(obj, clip.first_frame, n, fps)
        out.append((s.name, clip.audio, text, times, values, names))
    return out


def start_mapping(obj) -> tuple[str, dict[str, dict[str, float]]]:
    """The viseme set and the mapping the mesh is animated with (its own, or
    the one Auto-Map would detect, which is not stored): the starting
    preset's poses on the mesh's keys, so learning starts from what
    generating shows."""
    st = obj.emotive_lipsync
    mp = st.mapping_dict()
    if mp:
        return run.mesh_viseme_set(obj).name, mp
    found = run.detect(obj)
    return found.convention.viseme_set, found.mapping


def work(data, viseme_set: str, emotion: str, name: str, holdout: float, progress=None,
         keep_learned: bool = False, start_map: dict | None = None) -> learning.Learned:
    """Align and fit (no Blender data touched: safe in a thread).
    ``start_map``: the mesh's mapping (:func:`start_mapping`); None: the
    viseme set's own names."""
    clips = []
    for k, (label, audio, text, times, values, names) in enumerate(data):
        if progress:
            progress("align", k / len(data))
        al = align_audio(audio, text)
        clips.append(learning.TrainingClip(label, audio, al, times, values, names))
    return learning.learn(clips, emotion=emotion, viseme_set=viseme_set, name=name, holdout=holdout,
                       progress=progress, keep_learned=keep_learned, start_map=start_map)


def summary(result: learning.Learned, path: str) -> tuple[str, str]:
    """The comparison with the starting preset on the held-out strips, in
    one line (the full table is in the report beside the preset)."""
    r = result.report
    le, st = r["summary"]["learned"], r["summary"]["start"]

    def num(v, fmt):
        return "-" if v is None else format(v, fmt)

    msg = (f"Learned preset {r['name']!r} from {len(r['clips']['train'])} clips ({r['evaluation']}, "
           f"{len(r['per_clip'])} held out): correlation {num(le['correlation'], '.3f')} vs "
           f"{num(st['correlation'], '.3f')} for {r['base_preset']}, RMSE {le['rmse']:.4f} vs {st['rmse']:.4f}, "
           f"peak timing {num(le['peak_timing_ms'], '.0f')} vs {num(st['peak_timing_ms'], '.0f')} ms")
    parts = r.get("parts", {})
    learned = f"; learned {', '.join(parts.get('learned', []))}, the rest kept from {r['base_preset']}"
    if r["kept"] == "start":
        return "WARNING", (msg + f": no part did better than {r['base_preset']}, so {r['name']!r} keeps "
                           f"{r['base_preset']}'s numbers (saved to {path})")
    if r["better_than_builtin"]:
        return "INFO", msg + learned + f"; saved to {path}"
    if parts.get("check") is None:
        return "WARNING", msg + f": NOT better than {r['base_preset']} (kept as asked; saved to {path})"
    return "INFO", msg + learned + f" (no track worse than with it; saved to {path})"


#: Where each step of :func:`work` lies in the whole: (start, share).
PHASES = learning.PHASES


def learn_job(scene, viseme_set: str, data, emotion: str, name: str, holdout: float,
              keep_learned: bool = False, start_map: dict | None = None) -> jobs.Job:
    """Learning as a job: the preset is saved with the user's presets and
    loaded into the scene's panel when it is done."""
    scene_name = scene.name

    def finish(result: learning.Learned) -> tuple[str, str]:
        path = os.path.join(userdata.folder(create=True), name + ".json")
        result.save(path)
        print(learning.summary_text(result.report))
        target = bpy.data.scenes.get(scene_name)
        if target is not None:
            target.emotive_lipsync.load_preset(result.preset, name)
        return summary(result, path)

    return jobs.Job(jobs.LEARN, f"Learning preset {name!r}",
                    lambda progress: work(data, viseme_set, emotion, name, holdout, progress, keep_learned,
                                          start_map), finish,
                    phases=PHASES)


class LIPSYNC_OT_learn_preset(jobs.ModalJob, bpy.types.Operator):
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
                           description="Share of the strips kept aside to check the learned preset when there "
                                       "are more than 8 (with fewer, each strip is held out in turn)")
    keep_learned: BoolProperty(name="Keep Learned", default=False,
                               description="Keep every learned part (timing and poses), even those not better "
                                           "than the preset it started from on the held-out strips")

    def _prepare(self, context):
        obj = face(context, self.mesh)
        if self.emotion not in presets.builtin_names():
            raise LipSyncError(f"start from a built-in preset: {', '.join(presets.builtin_names())}")
        name = userdata.check_name(self.name)
        if name in presets.builtin_names():
            raise LipSyncError(f"{name!r} is a built-in preset: choose another name for the learned one")
        if obj.emotive_lipsync.viseme_set == "FILE":
            raise LipSyncError("learning needs one of the built-in viseme sets on the mesh")
        names = [n.strip() for n in self.strips.split(",") if n.strip()]
        data = collect(context.scene, obj, names)
        vset, mp = start_mapping(obj)
        return obj, vset, data, mp

    def _job(self, context) -> jobs.Job:
        _obj, vset, data, mp = self._prepare(context)
        return learn_job(context.scene, vset, data, self.emotion, userdata.check_name(self.name), self.holdout,
                         self.keep_learned, mp)

    def execute(self, context):
        try:
            outcome = self._job(context).run()
        except Exception as exc:  # noqa: BLE001 - reported, never a traceback in the UI
            outcome = jobs.failure(self.bl_label, exc)
        self.report({outcome.level}, outcome.message)
        return {"FINISHED"} if outcome.finished else {"CANCELLED"}

    def invoke(self, context, _event):
        if bpy.app.background or context.window is None:
            return self.execute(context)
        try:
            jobs.ensure_free(jobs.LEARN)
            job = self._job(context)
        except Exception as exc:  # noqa: BLE001
            outcome = jobs.failure(self.bl_label, exc)
            self.report({outcome.level}, outcome.message)
            return {"CANCELLED"}
        return self.run_modal(context, job)


classes = (LIPSYNC_OT_learn_preset,)
