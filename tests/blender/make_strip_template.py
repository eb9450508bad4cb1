"""Write ``strip_template.blend``: one long sound strip, for the tests on a
``bpy`` built without Audaspace (PyPI's 4.2 wheel), which cannot add sound
strips but keeps those it reads from a .blend (see ``sample_rigs/sound_strips.py``).

    .venv-bpy45/bin/python tests/blender/make_strip_template.py

Run it with Blender 4.5 (a Blender with audio whose files 4.2 reads).  The
strip is made from ten minutes of silence at 30 fps (18000 frames), enough
for any test line; the tests give it their own sound and trim it.
"""

from __future__ import annotations

import os
import sys
import tempfile
import wave

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "strip_template.blend")
SCENE = "strip_template"
SECONDS = 600


def main() -> int:
    os.environ["BLENDER_USER_RESOURCES"] = tempfile.mkdtemp(prefix="lipsync-user-")
    import bpy

    if not bpy.app.build_options.audaspace or bpy.app.version[:2] != (4, 5):
        print("make_strip_template: run this with Blender 4.5's bpy (.venv-bpy45)", file=sys.stderr)
        return 1
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.name = SCENE
    scene.render.fps, scene.render.fps_base = 30, 1.0
    with tempfile.TemporaryDirectory() as tmp:
        silence = os.path.join(tmp, "silence.wav")
        with wave.open(silence, "wb") as w:
            w.setnchannels(1)
            w.setsampwidth(1)
            w.setframerate(8000)
            w.writeframes(b"\x80" * (8000 * SECONDS))
        strip = scene.sequence_editor_create().strips.new_sound("template", silence, 1, 1)
        strip.sound.filepath = "//silence.wav"  # the tests replace the sound
        assert strip.frame_duration == 30 * SECONDS
    bpy.ops.wm.save_as_mainfile(filepath=OUT, compress=True)
    print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
