"""A sound strip on any ``bpy``, for the sample job and the tests.

Blender adds a sound strip with its sound library (Audaspace).  PyPI's
``bpy`` 4.2 is built without it and refuses ("Blender compiled without
Audaspace support"), but keeps the sound strips it reads from a .blend.
There the strip is pasted, through the sequencer's clipboard, from
``tests/blender/strip_template.blend`` (one sound strip 18000 frames long,
made by ``tests/blender/make_strip_template.py`` with Blender 4.5), given
the sound of the file and trimmed to the length Blender gives a new strip
of that sound: its duration times the scene's fps, rounded (checked
against Blender 4.5 on the test audio).  Only WAV files, whose duration the
``wave`` module reads.  A real Blender plays such a strip as any other.
"""

from __future__ import annotations

import os
import wave

import bpy

TEMPLATE = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tests", "blender",
                        "strip_template.blend")


def add(compat, scene, name: str, path: str, frame: int = 1, channel: int = 1):
    """A sound strip of ``path`` on ``channel`` of ``scene``, its sound
    starting at ``frame``.  ``compat`` is the extension's version shim
    (``blender/compat.py``) of the add-on in use."""
    if compat.AUDASPACE:
        return compat.new_sound_strip(scene, name, path, channel, frame)
    return _paste(compat, scene, name, path, channel, frame)


def _paste(compat, scene, name, path, channel, frame):
    with bpy.data.libraries.load(TEMPLATE, link=False) as (_src, dst):
        dst.scenes = ["strip_template"]
    template = dst.scenes[0]
    if scene.sequence_editor is None:
        scene.sequence_editor_create()
    for s in compat.all_strips(scene):
        s.select = False
    before = set(compat.all_strips(scene))
    win = bpy.context.window_manager.windows[0]
    area = win.screen.areas[0]
    old_type, area.type = area.type, "SEQUENCE_EDITOR"
    region = next(r for r in area.regions if r.type == "WINDOW")
    ctx = dict(window=win, area=area, region=region, scene=template)
    try:
        win.scene = template  # the copy operator reads the window's scene
        with bpy.context.temp_override(**ctx):
            compat.all_strips(template)[0].select = True
            assert bpy.ops.sequencer.copy() == {"FINISHED"}
        win.scene = scene
        with bpy.context.temp_override(**dict(ctx, scene=scene)):
            assert bpy.ops.sequencer.paste(keep_offset=True) == {"FINISHED"}
    finally:
        win.scene = scene
        area.type = old_type
        bpy.data.scenes.remove(template)
    (strip,) = set(compat.all_strips(scene)) - before
    placeholder = strip.sound
    strip.sound = bpy.data.sounds.load(path, check_existing=False)
    if placeholder.users == 0:
        bpy.data.sounds.remove(placeholder)
    strip.name, strip.channel, strip.frame_start = name, channel, frame
    with wave.open(bpy.path.abspath(path)) as w:
        seconds = w.getnframes() / w.getframerate()
    length = max(1, round(seconds * scene.render.fps / scene.render.fps_base))
    strip.frame_offset_end = strip.frame_duration - length
    return strip
