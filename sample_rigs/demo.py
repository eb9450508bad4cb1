"""The sample job: build the two sample characters, lip-sync the shipped
line onto both headless, save a .blend and render a contact sheet.

    .venv/bin/python sample_rigs/demo.py [OUT_DIR]      (default: out/)

Ada speaks happily with the rule model, Kit neutrally with dominance
functions, so the two show the presets' and the models' difference.  The
add-on runs from this checkout.
"""

from __future__ import annotations

import os
import sys
import time

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SPEECH = os.path.join(HERE, "speech", "hello.wav")


def contact_sheet(scene, frames, path, cols=6):
    """Render ``frames`` with Workbench and tile them into one PNG."""
    tiles = []
    tmp = os.path.join(os.path.dirname(path), "_frame.png")
    for f in frames:
        scene.frame_set(f)
        scene.render.filepath = tmp
        bpy.ops.render.render(write_still=True)
        img = bpy.data.images.load(tmp)
        w, h = img.size
        px = np.empty(w * h * 4, dtype=np.float32)
        img.pixels.foreach_get(px)
        tiles.append(px.reshape(h, w, 4))
        bpy.data.images.remove(img)
    os.remove(tmp)
    h, w = tiles[0].shape[:2]
    rows = (len(tiles) + cols - 1) // cols
    sheet = np.ones((rows * h, cols * w, 4), dtype=np.float32)
    for i, t in enumerate(tiles):
        r, c = divmod(i, cols)
        # Image rows run bottom-up in Blender: the first tile goes on top.
        sheet[(rows - 1 - r) * h:(rows - r) * h, c * w:(c + 1) * w] = t
    out = bpy.data.images.new("contact_sheet", cols * w, rows * h, alpha=True)
    out.pixels.foreach_set(sheet.ravel())
    out.filepath_raw = path
    out.file_format = "PNG"
    out.save()
    bpy.data.images.remove(out)


def main(argv):
    out_dir = os.path.abspath(argv[0] if argv else os.path.join(ROOT, "out"))
    os.makedirs(out_dir, exist_ok=True)
    sys.path.insert(0, ROOT)
    sys.path.insert(0, HERE)
    import addon
    import build_rigs
    from addon.blender import command, compat

    t0 = time.perf_counter()
    build_rigs.build_scene()
    addon.register()
    scene = bpy.context.scene
    text = bpy.data.texts.new("hello.txt")
    with open(os.path.splitext(SPEECH)[0] + ".txt", encoding="utf-8") as fh:
        text.from_string(fh.read())
    # Strips named after their meshes: "Generate for All Strips" and the
    # command line find the face by the name.
    ada_strip = compat.new_sound_strip(scene, "Ada_hello", SPEECH, 1, 1)
    kit_strip = compat.new_sound_strip(scene, "Kit_hello", SPEECH, 2, 1)
    ada_strip["lipsync_text"] = kit_strip["lipsync_text"] = text.name
    scene.frame_start, scene.frame_end = 1, max(ada_strip.frame_final_end, kit_strip.frame_final_end)
    blend = os.path.join(out_dir, "sample.blend")
    # Ada through the operator the Generate button runs, Kit through the
    # batch command (`blender -b ... --command lipsync`), which also saves.
    if bpy.ops.emotive_lipsync.generate(strip="Ada_hello", mesh="Ada", emotion="happy",
                                        coarticulation="rules") != {"FINISHED"}:
        return 1
    status = command.execute(["--strip", "Kit_hello", "--emotion", "neutral", "--output", blend])
    if status:
        return status
    sheet = os.path.join(out_dir, "sample_contact_sheet.png")
    first, last = scene.frame_start, scene.frame_end
    contact_sheet(scene, [int(f) for f in np.linspace(first + 8, last - 8, 12)], sheet)
    print(f"wrote {blend}")
    print(f"wrote {sheet} (12 frames from {first}-{last})")
    print(f"demo took {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
