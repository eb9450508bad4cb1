"""The Generate operator in Blender, headless, on a ~100 s line at 30 fps
onto a rig with 15 shape keys (the Oculus visemes).

* total time of ``emotive_lipsync.generate`` (engine included), as a share
  of the audio's duration (target: at most 0.1);
* the keyframing step alone (target: under 100 ms), with a key on every
  frame and with key reduction, and the same keys written with
  ``keyframe_insert`` for comparison.

The line is the two LibriVox sonnets joined (../shared/data) when present,
else the shipped sample repeated to 100 s.

    .venv/bin/python bench/blender_generate.py
"""

from __future__ import annotations

import dataclasses
import os
import sys
import tempfile
import time

import bpy
import numpy as np

from common import DATA, ROOT, write_wav

sys.path.insert(0, str(ROOT / "sample_rigs"))
import build_rigs

OCULUS = {"viseme_sil": {}, "viseme_PP": {"close": 1.0}, "viseme_FF": {"tuck_lower": 1.0},
          "viseme_TH": {"open": 0.22}, "viseme_DD": {"open": 0.18, "wide": 0.2},
          "viseme_kk": {"open": 0.3}, "viseme_CH": {"round": 0.55, "open": 0.15},
          "viseme_SS": {"open": 0.06, "wide": 0.45}, "viseme_nn": {"open": 0.2},
          "viseme_RR": {"round": 0.45, "open": 0.12}, "viseme_aa": {"open": 0.85},
          "viseme_E": {"open": 0.5, "wide": 0.45}, "viseme_ih": {"open": 0.18, "wide": 0.65},
          "viseme_oh": {"open": 0.55, "round": 0.7}, "viseme_ou": {"open": 0.12, "round": 1.0}}



def the_line(tmp):
    from addon.engine import audio as audio_mod

    if (DATA / "librivox" / "p002.mp3").is_file():
        parts = [audio_mod.load(DATA / "librivox" / f"{n}.mp3") for n in ("p002", "p003")]
        text = " ".join((DATA / "librivox" / f"{n}.txt").read_text() for n in ("p002", "p003"))
        label = "LibriVox sonnets p002+p003"
    else:
        one = audio_mod.load(ROOT / "sample_rigs" / "speech" / "hello.wav")
        reps = int(np.ceil(100 / one.duration))
        parts = [one] * reps
        text = " ".join([(ROOT / "sample_rigs" / "speech" / "hello.txt").read_text()] * reps)
        label = f"sample line x{reps}"
    samples = np.concatenate([p.samples for p in parts])
    path = os.path.join(tmp, "line.wav")
    write_wav(path, samples)
    return path, text, len(samples) / 16000, label


def main():
    import addon
    from addon.blender import compat, keying, run, sources

    tmp = tempfile.mkdtemp()
    path, text, duration, label = the_line(tmp)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon.register()
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = 30, 1.0
    rig = build_rigs.build_character("Face", OCULUS)
    assert len(rig.data.shape_keys.key_blocks) - 1 == 15
    compat.new_sound_strip(scene, "line", path, 1, 1)
    scene.emotive_lipsync.text = text
    print(f"{label}: {duration:.1f} s of audio, rig with 15 shape keys, 30 fps")

    totals = []
    for _ in range(3):
        t0 = time.perf_counter()
        assert bpy.ops.emotive_lipsync.generate(mesh="Face") == {"FINISHED"}
        totals.append(time.perf_counter() - t0)
    best = min(totals)
    print(f"  Generate operator, total (best of 3): {best:.2f} s = {best / duration:.3f} x audio "
          f"(target <= 0.1)")

    clip = sources.strip_clip(scene, sources.strip_by_name(scene, "line"))
    line = sources.LineInputs(rig, clip, text)
    opts = dataclasses.replace(run.options(scene), tolerance=0.0)
    again = run.generate(scene, line, opts)
    keying.clear(rig)
    fresh = run.generate(scene, line, opts)
    print(f"  engine inside it: {fresh.timings['engine']:.2f} s")
    keying.clear(rig)
    reduced = run.generate(scene, line, dataclasses.replace(opts, tolerance=0.02))
    print(f"  keyframing {fresh.keys} keys on {fresh.shape_keys} shape keys (target < 100 ms): "
          f"{1000 * fresh.timings['keying']:.1f} ms on new F-curves, "
          f"{1000 * again.timings['keying']:.1f} ms replacing a previous run")
    print(f"  with key reduction (tolerance 0.02): {reduced.keys} keys in "
          f"{1000 * reduced.timings['keying']:.1f} ms")

    # The same keys written one by one, as most add-ons do.
    keying.clear(rig)
    from addon.engine import mapping, pipeline
    from addon.engine.settings import LineSettings

    result = pipeline.analyze(clip.audio, text, LineSettings.of(viseme_set="oculus", fps=30))
    names, values = mapping.shape_key_curves(result.curves, result.viseme_set.visemes,
                                             rig.emotive_lipsync.mapping_dict())
    kbs = rig.data.shape_keys.key_blocks
    t0 = time.perf_counter()
    for j, n in enumerate(names):
        kb = kbs[n]
        for f, v in enumerate(values[:, j]):
            kb.value = float(v)
            kb.keyframe_insert("value", frame=1 + f)
    slow = time.perf_counter() - t0
    print(f"  for comparison, keyframe_insert per key: {slow:.2f} s for {values.size} keys")
    return 0


if __name__ == "__main__":
    sys.exit(main())
