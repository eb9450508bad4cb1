"""Real characters' naming conventions, one click each: how many shape keys
Generate drives and how far the lips open, measured on the mesh Blender
evaluates.

For each test head of ``tests/blender/heads.py`` (a lip-and-jaw mesh whose
keys are built the way the convention builds them: ARKit's ``mouthClose``
closes the lips only on an open jaw, a ``viseme_PP`` presses closed lips ...)
Generate runs with nothing set up on "Maybe Bobby makes pumpkin pie, baby."
read fast and slowly, and the script prints:

* the convention detected and the shape keys driven;
* the mouth opening at every /p b m/ (largest |opening| over the sound's
  frames; 0 = lips together);
* the peak opening of each open vowel lasting two frames or more (1 = as open
  as the head's open shape alone: jawOpen, viseme_aa, Fcl_MTH_A ...);
* the lowest opening anywhere (negative = lips pushed through each other).

    .venv/bin/python bench/characters.py
"""

from __future__ import annotations

import sys

import bpy

from common import ROOT

sys.path.insert(0, str(ROOT / "tests" / "blender"))
sys.path.insert(0, str(ROOT / "sample_rigs"))
from heads import FPS, HEADS, build_head, measure

TEXT = "Maybe Bobby makes pumpkin pie, baby."
LINES = ((ROOT / "tests" / "fixtures" / "fast_bilabials.wav", 1), (ROOT / "tests" / "fixtures" /
                                                                    "slow_bilabials.wav", 101))


def main() -> int:
    import addon
    from addon.blender import compat, run, sources
    from addon.engine.alignment import align_audio

    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon.register()
    phones = [align_audio(sources.decode(str(path)), TEXT).phones for path, _f in LINES]
    print(f"{'head':24} {'convention':44} {'keys':>4}  {'/p b m/ max':>11}  {'open vowels min..max':>20}  "
          f"{'lowest':>7}")
    worst_closed, worst_low = 0.0, 0.0
    for name, (keys, open_key) in HEADS.items():
        bpy.ops.wm.read_factory_settings(use_empty=True)
        scene = bpy.context.scene
        scene.render.fps, scene.render.fps_base = FPS, 1.0
        obj = build_head("Face", keys)
        for path, first in LINES:
            compat.new_sound_strip(scene, path.stem, str(path), 1 if first == 1 else 2, first)
            assert bpy.ops.emotive_lipsync.generate(mesh="Face", strip=path.stem, text=TEXT) == {"FINISHED"}
        closed, vowels, lowest = [], [], []
        for ph, (_path, first) in zip(phones, LINES):
            c, v, low = measure(obj, open_key, ph, first)
            closed += list(c)
            vowels += list(v)
            lowest.append(low)
        driven = {k for mix in obj.emotive_lipsync.mapping_dict().values() for k in mix}
        driven |= set(run.conventions.Closure.from_json(obj.emotive_lipsync.closure_rule).relative)
        worst_closed, worst_low = max(worst_closed, max(closed)), min(worst_low, min(lowest))
        print(f"{name:24} {obj.emotive_lipsync.convention[:44]:44} {len(driven):>4}  {max(closed):>11.3f}  "
              f"{min(vowels):>9.2f}..{max(vowels):<9.2f}  {min(lowest):>7.3f}")
    print(f"over all heads: lips at /p b m/ at most {worst_closed:.3f} apart; lowest opening {worst_low:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
