"""The expression layer checked on lines the tests never see: the human
sample head (``sample_rigs/human.py``, ARKit variant: all 52 blendshapes
on a sculpted face) lip-synced under each built-in preset, keyed the way a
run keys it, and measured on its keys and on the mesh Blender evaluates.

Per line and preset it prints:

* each of the preset's EMFACS units: the mean value of its shape keys
  while speaking (first phone to last), less neutral's mean of the same
  keys on the same line (speech drives some of them too: ``mouthSmile*``
  on /iy/, ``jawOpen`` everywhere); the issue's bar is 0.2;
* under neutral, the upper face (the brow, eye and cheek keys: AU1, AU2,
  AU4, AU5, AU6, AU7): the largest value any of them takes over the line
  and the largest standard deviation of one (both 0: still);
* the lip gap at every /p b m/ (:func:`heads.measure`: the lower lip's
  motion against the upper lip, in units of ``jawOpen`` at 1, about 3 cm on
  this head; the tests' bound is 0.05 either way), its largest magnitude
  and the number of /p b m/.

Lines: a LibriSpeech utterance and two praatIO sentences from
``../shared/data`` (``mfa/61-70968-0000.flac``, ``praatio/bobby.wav``,
``praatio/mary.wav``); without that folder, the sample line
``sample_rigs/speech/hello.wav``.

    .venv/bin/python bench/expression.py
"""

from __future__ import annotations

import os
import sys
import time

import numpy as np

from common import DATA, ROOT

sys.path[:0] = [str(ROOT / "sample_rigs"), str(ROOT / "tests" / "blender")]

import bpy

import human
from heads import BILABIALS, FPS, measure

EMOTIONS = ("neutral", "happy", "sad", "angry", "surprised", "afraid", "disgusted")
UPPER = ("AU1", "AU2", "AU4", "AU5", "AU6", "AU7")      # brows, eyes, cheeks
BAR = 0.2
GAP = 0.05


def lines() -> list[tuple[str, str, str]]:
    """(name, audio path, transcript) of the held-out lines."""
    libri = DATA / "mfa" / "61-70968-0000"
    held = [("61-70968-0000", libri.with_suffix(".flac"), lambda: libri.with_suffix(".lab").read_text("utf-8")),
            ("bobby", DATA / "praatio" / "bobby.wav", lambda: "Bobby ripped the ledger"),
            ("mary", DATA / "praatio" / "mary.wav", lambda: "Mary rolled the barrel")]
    out = [(name, str(audio), text()) for name, audio, text in held if audio.is_file()]
    if not out:
        print(f"{DATA} is not here (set LIPSYNC_DATA to the recordings folder): the sample line instead")
        speech = ROOT / "sample_rigs" / "speech"
        out.append(("hello (sample)", str(speech / "hello.wav"), (speech / "hello.txt").read_text("utf-8")))
    return out


def key_values(obj, names, frames, compat) -> dict[str, np.ndarray]:
    """Each shape key's value on ``frames`` (its F-curve; 0 where unkeyed)."""
    out = {}
    for n in names:
        fc = compat.find_fcurve(obj.data.shape_keys, f'key_blocks["{n}"].value')
        out[n] = np.array([fc.evaluate(f) for f in frames]) if fc is not None else np.zeros(len(frames))
    return out


def run_line(name, path, text, modules) -> bool:
    run, sources, pipeline, presets, compat, align_audio = modules
    scene = bpy.context.scene
    audio = sources.decode(path)
    t0 = time.perf_counter()
    al = align_audio(audio, text)
    phones = al.phones
    first = 1 + int(np.ceil(phones[0].start * FPS))
    last = 1 + int(np.floor(phones[-1].end * FPS))
    speaking = np.arange(first, last + 1)
    n_closures = sum(p.phone in BILABIALS for p in phones)
    print(f"\n{name}: {len(al.words)} words, {n_closures} /p b m/, {audio.duration:.1f} s "
          f"(aligned in {time.perf_counter() - t0:.1f} s)")
    print(f"  {'preset':10} {'units: mean key value while speaking - neutral':58} {'lip gap at /p b m/':>20}")
    clip = sources.Clip(audio, 1, name, path)
    neutral_means, ok = {}, True
    for emotion in EMOTIONS:
        for old in [o for o in bpy.data.objects if o.name.startswith("Held")]:
            bpy.data.objects.remove(old)
        obj = human.build("Held", "arkit")
        plan = run.plan(scene, sources.LineInputs(obj, clip, text), run.options(scene, emotion=emotion))
        result = pipeline.analyze(audio, settings=plan.options.line, alignment=al)
        run.key(obj, plan, run.Analysis(result, 0.0))
        mapping = plan.expression.mapping
        keys = sorted({k for mix in mapping.values() for k in mix})
        values = key_values(obj, keys, speaking, compat)
        means = {u: float(np.mean([values[k].mean() for k in mix])) for u, mix in mapping.items()}
        if emotion == "neutral":
            neutral_means = means
            upper = [k for u in UPPER for k in mapping.get(u, {})]
            whole = key_values(obj, upper, np.arange(1, last + 30), compat)
            peak = max(float(np.abs(v).max()) for v in whole.values())
            spread = max(float(v.std()) for v in whole.values())
            units = f"upper face ({len(upper)} keys): max {peak:.3f}, std {spread:.3f}"
            ok &= peak == 0.0
        else:
            deltas = {u: means[u] - neutral_means[u] for u in sorted(plan.options.line.emotion.expression,
                                                                     key=lambda u: int(u[2:]))}
            units = "  ".join(f"{u} {d:+.2f}" for u, d in deltas.items())
            low = min(deltas.values())
            units += f"  (min {low:+.2f}{'' if low >= BAR else ' < ' + str(BAR)})"
            ok &= low >= BAR
        lips = [v.index for v in obj.data.vertices
                if any(g.group == obj.vertex_groups["lips"].index for g in v.groups)]
        closed, _vowels, lowest = measure(obj, "jawOpen", phones, 1, among=lips)
        worst = float(np.abs(closed).max()) if len(closed) else 0.0
        gaps = f"max |gap| {worst:.3f} (lowest {lowest:+.3f})"
        ok &= worst <= GAP and lowest >= -GAP
        print(f"  {emotion:10} {units:58} {gaps:>20}")
    return ok


def main() -> int:
    sys.path.insert(0, str(ROOT))
    import addon
    from addon.blender import compat, run, sources
    from addon.engine import pipeline, presets
    from addon.engine.alignment import align_audio

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = FPS, 1.0
    addon.register()
    try:
        print("held-out check of the expression layer on the human sample head (ARKit), "
              f"Blender {bpy.app.version_string}")
        ok = True
        for name, path, text in lines():
            ok &= run_line(name, path, text, (run, sources, pipeline, presets, compat, align_audio))
        print(f"\n{'all' if ok else 'NOT all'} within the bars: units >= {BAR} above neutral, neutral's upper "
              f"face still, |lip gap| <= {GAP} at every /p b m/")
    finally:
        addon.unregister()
    return 0


if __name__ == "__main__":
    status = main()
    if not bpy.app.binary_path and bpy.app.version < (4, 4, 0):
        # PyPI's bpy 4.2 and 4.3 crash while Python shuts down once an add-on was registered.
        sys.stdout.flush()
        os._exit(status)
    sys.exit(status)
