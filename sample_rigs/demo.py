"""The sample job: build the human sample head in its two variants,
lip-sync the shipped line onto both headless, save a .blend, render a
contact sheet of labelled phones and a video with the sound.

    .venv/bin/python sample_rigs/demo.py [OUT_DIR] [--blend-only]     (default: out/)

Writes ``sample.blend`` (press play), ``sample_contact_sheet.png`` (twelve
frames at chosen phones: lips closed on /p b m/, lower lip to the upper
teeth on /f v/, rounded and open vowels; the ARKit head on the left of each
frame, the Ready Player Me one on the right), ``sample_emotions.png`` (the
ARKit head at one phone of the line under each of the seven built-in
emotion presets, labelled with the preset and the FACS action units it
sets: brows, lids, cheeks and mouth) and ``sample.mp4`` (the whole line
with its sound, where this Blender can write video); with
``--blend-only``, the .blend alone.

A .blend opens in the Blender that saved it and in later ones, not in
earlier ones: one saved by 5.0 opens in 4.5 and later (5.0 writes a file
header 4.2 cannot read), one saved by 4.2 in every Blender the extension
supports.  ``./setup.sh`` therefore saves ``sample.blend`` again with 4.2
(``.venv-bpy42/bin/python sample_rigs/demo.py out --blend-only``) when that
environment exists.  PyPI's ``bpy`` 4.2 has no sound library to add sound
strips with; the strips are then pasted from a template .blend (see
``sound_strips.py``) and play as usual in Blender 4.2.

The ARKit head ("Human") is lip-synced through the operator the Generate
button runs, the Ready Player Me head ("HumanRPM") through the batch command
(``blender -b ... --command lipsync``), which also saves the file; both with
nothing set up, so the naming convention is recognised on each.  The
add-on runs from this checkout; the head's assets are fetched by
``human.py`` (once, into its cache folder).
"""

from __future__ import annotations

import contextlib
import math
import os
import sys
import time

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SPEECH = os.path.join(HERE, "speech", "hello.wav")

HEADS = (("Human", "arkit", "ARKit 52 blendshapes"), ("HumanRPM", "rpm", "Ready Player Me visemes"))
SPACING = 0.2             # m between the two heads
VIEW = (0.4, 0.2)         # m of the front view (orthographic): both faces, eyes to chin
TILE = (800, 400)         # pixels of one frame of the sheet
VIDEO = (640, 320)        # pixels of a frame of the video

#: The phones shown, in the order of the sheet: (ARPAbet phone, what it shows).
#: Each is taken at its first occurrence in the line after the ones before
#: it of the same kind, so the sheet spreads over the whole line.
SHOWN = (
    ("M", "lips closed"), ("B", "lips closed"), ("P", "lips closed"), ("M", "lips closed"),
    ("V", "lower lip to upper teeth"), ("V", "lower lip to upper teeth"),
    ("OW", "rounded"), ("UW", "rounded"), ("OY", "rounded"),
    ("AA", "open"), ("AE", "open"), ("AY", "open"),
)
VOWELS = {"OW", "UW", "OY", "AA", "AE", "AY"}

#: The emotions sheet: the ARKit head under each built-in preset, at one
#: phone of the line, its face from the brows to the chin.
EMOTIONS = ("neutral", "happy", "sad", "angry", "surprised", "afraid", "disgusted")
EMOTION_PHONE = ("EH", "very")    # (phone, in the word)
EMOTION_VIEW = (0.18, 0.2)          # m: the face and a strip of text above and below
EMOTION_TILE = (432, 480)           # pixels of one frame of the emotions sheet


def _material(name, rgba):
    mat = bpy.data.materials.get(name) or bpy.data.materials.new(name)
    mat.diffuse_color = rgba
    return mat


def _text(name, body, location, size):
    curve = bpy.data.curves.new(name, "FONT")
    curve.body, curve.size, curve.align_x, curve.align_y = body, size, "CENTER", "CENTER"
    obj = bpy.data.objects.new(name, curve)
    obj.location, obj.rotation_euler = location, (math.radians(90), 0, 0)
    obj.data.materials.append(_material("Label", (0.05, 0.05, 0.05, 1)))
    bpy.context.scene.collection.objects.link(obj)
    return obj


def _band(name, z0, z1):
    """A white strip across the view in front of the heads, for text."""
    mesh = bpy.data.meshes.new(name)
    w, y = VIEW[0], -0.15
    mesh.from_pydata([(-w, y, z0), (w, y, z0), (w, y, z1), (-w, y, z1)], [], [(0, 1, 2, 3)])
    mesh.materials.append(_material("Band", (1, 1, 1, 1)))
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def build_scene():
    """The two heads side by side, an orthographic front camera framing
    their faces, a white strip with the label line above them and one with
    their captions below, ready to render with Workbench."""
    import human

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bottom, top = 0.01, 0.01 + VIEW[1]
    strip = 0.12 * VIEW[1]
    heads = {}
    for k, (name, variant, caption) in enumerate(HEADS):
        x = (k - 0.5) * SPACING
        heads[name] = human.build(name, variant, (x, 0.0, 0.0))
        _text(f"{name}_caption", caption, (x, -0.16, bottom + strip / 2), 0.45 * strip)
    _band("CaptionStrip", bottom - 0.01, bottom + strip)
    _band("LabelStrip", top - strip, top + 0.01)
    label = _text("Label", "", (0.0, -0.16, top - strip / 2), 0.5 * strip)
    human.credit_scene(scene)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.data.type, cam.data.ortho_scale = "ORTHO", VIEW[0]
    cam.location = (0.0, -1.0, (bottom + top) / 2)
    cam.rotation_euler = (math.radians(90), 0, 0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.display.shading.color_type = "MATERIAL"
    scene.display.shading.light = "STUDIO"
    scene.display.shading.show_cavity = True
    scene.view_settings.view_transform = "Standard"
    scene.world = bpy.data.worlds.new("Backdrop")
    scene.world.color = (0.86, 0.87, 0.89)
    scene.render.resolution_x, scene.render.resolution_y = TILE
    scene.render.fps, scene.render.fps_base = 30, 1.0
    return heads, label


@contextlib.contextmanager
def _quiet():
    """Blender's per-frame render messages on stdout, silenced."""
    sys.stdout.flush()
    saved = os.dup(1)
    with open(os.devnull, "w") as null:
        os.dup2(null.fileno(), 1)
    try:
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)


def render_pixels(scene) -> np.ndarray:
    """The current frame rendered, as (h, w, 4) floats, bottom row first."""
    tmp = os.path.join(bpy.app.tempdir, "_frame.png")
    scene.render.filepath = tmp
    with _quiet():
        bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(tmp)
    w, h = img.size
    px = np.empty(w * h * 4, dtype=np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    os.remove(tmp)
    return px.reshape(h, w, 4)


def save_sheet(tiles, path, cols=4):
    """Tile rendered frames, first on top, into one PNG."""
    h, w = tiles[0].shape[:2]
    rows = (len(tiles) + cols - 1) // cols
    sheet = np.ones((rows * h, cols * w, 4), dtype=np.float32)
    for i, t in enumerate(tiles):
        r, c = divmod(i, cols)
        # Image rows run bottom-up in Blender: the first tile goes on top.
        sheet[(rows - 1 - r) * h:(rows - r) * h, c * w:(c + 1) * w] = t
        sheet[(rows - 1 - r) * h:(rows - r) * h, c * w:c * w + 1, :3] = 0.6     # thin grid lines
        sheet[(rows - 1 - r) * h:(rows - 1 - r) * h + 1, c * w:(c + 1) * w, :3] = 0.6
    out = bpy.data.images.new("contact_sheet", cols * w, rows * h, alpha=True)
    out.pixels.foreach_set(sheet.ravel())
    out.filepath_raw = path
    out.file_format = "PNG"
    out.save()
    bpy.data.images.remove(out)


def chosen_frames(scene, alignment, first, face):
    """(frame, label) for each phone of :data:`SHOWN`, the line starting on
    frame ``first``: a consonant's middle frame; a vowel's frame where the
    mouth of ``face`` (an ARKit head) is most open or rounded."""
    keys = face.data.shape_keys.key_blocks
    out, used = [], set()
    fps = scene.render.fps / scene.render.fps_base
    for phone, what in SHOWN:
        k, p = next(((k, p) for k, p in enumerate(alignment.phones) if p.phone == phone and k not in used),
                    (None, None))
        if p is None:
            continue
        used.add(k)
        span = range(first + int(np.ceil(p.start * fps)), first + int(np.floor(p.end * fps)) + 1)
        frame = first + int(round((p.start + p.end) / 2 * fps))
        if phone in VOWELS and len(span):
            def shape(f):
                scene.frame_set(f)
                return sum(keys[n].value for n in ("jawOpen", "mouthFunnel", "mouthPucker"))
            frame = max(span, key=shape)
        word = alignment.words[p.word_index].text
        out.append((frame, f"/{phone.lower()}/ in \"{word}\" ({what}), frame {frame}"))
    return sorted(out)


def emotions_sheet(scene, heads, label, audio, alignment, transcript, path) -> float:
    """Render the emotions sheet (module docstring) into ``path``: a fresh
    ARKit head in the place of "Human", keyed under each of :data:`EMOTIONS`
    the way a run keys it (the line's alignment made once), one frame each
    at the middle of :data:`EMOTION_PHONE`, labelled with the preset and the
    action units it sets.  Everything it adds is removed again, and what it
    changed is put back.  Returns the seconds it took."""
    import human
    from addon.blender import run, sources
    from addon.engine import pipeline

    t0 = time.perf_counter()
    src = heads["Human"]
    phone, word = EMOTION_PHONE
    p = next(p for p in alignment.phones if p.phone == phone and alignment.words[p.word_index].text.lower()
             .strip(".,!?") == word)
    fps = scene.render.fps / scene.render.fps_base
    frame = 1 + int(round((p.start + p.end) / 2 * fps))
    face = human.build("HumanEmotions", "arkit", tuple(src.location))
    caption = bpy.data.objects[f"{src.name}_caption"]
    saved = (scene.camera, scene.render.resolution_x, scene.render.resolution_y, tuple(label.location),
             caption.data.body)
    cam = bpy.data.objects.new("EmotionCamera", bpy.data.cameras.new("EmotionCamera"))
    cam.data.type, cam.data.ortho_scale = "ORTHO", max(EMOTION_VIEW)
    top = VIEW[1] + 0.01                   # the label strip's top (build_scene)
    cam.location = (src.location.x, -1.0, top - EMOTION_VIEW[1] / 2)
    cam.rotation_euler = (math.radians(90), 0, 0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.resolution_x, scene.render.resolution_y = EMOTION_TILE
    label.location.x = src.location.x
    src.hide_render = True
    clip = sources.Clip(audio, 1, "hello", SPEECH)
    tiles = []
    try:
        for emotion in EMOTIONS:
            plan = run.plan(scene, sources.LineInputs(face, clip, transcript), run.options(scene, emotion=emotion))
            result = pipeline.analyze(audio, settings=plan.options.line, alignment=alignment)
            run.key(face, plan, run.Analysis(result, 0.0))
            units = plan.options.line.emotion.expression
            label.data.body = emotion
            caption.data.body = " + ".join(sorted(units, key=lambda u: int(u[2:]))) or "no expression"
            scene.frame_set(frame)
            tiles.append(render_pixels(scene))
    finally:
        scene.camera, scene.render.resolution_x, scene.render.resolution_y, label.location, body = saved
        caption.data.body, label.data.body = body, ""
        src.hide_render = False
        mesh, key = face.data, face.data.shape_keys
        action = key.animation_data.action if key and key.animation_data else None
        bpy.data.objects.remove(face)
        bpy.data.meshes.remove(mesh)
        if action is not None:
            bpy.data.actions.remove(action)
        bpy.data.objects.remove(cam)
    h, w = tiles[0].shape[:2]
    tiles.append(np.ones((h, w, 4), dtype=np.float32))     # 7 frames on a 4 x 2 sheet
    save_sheet(tiles, path)
    print(f"wrote {path} ({len(EMOTIONS)} presets at /{phone.lower()}/ in \"{word}\", frame {frame})")
    return time.perf_counter() - t0


def phone_labels(alignment, first, fps):
    """Per frame from ``first``: the word and phone being spoken."""
    def label(frame):
        t = (frame - first) / fps
        p = next((p for p in alignment.phones if p.start <= t < p.end), None)
        if p is None:
            return ""
        return f"\"{alignment.words[p.word_index].text}\"  /{p.phone.lower()}/"
    return label


def write_video(scene, path, label=None, text=None) -> bool:
    """The whole line as an MP4 (H.264, AAC sound), if this Blender has
    FFmpeg; ``label`` (frame -> text) is shown in the text object ``text``."""
    if not bpy.app.build_options.codec_ffmpeg:
        return False

    def on_frame(sc, *_args):
        text.data.body = label(sc.frame_current)

    if label is not None:
        bpy.app.handlers.frame_change_pre.append(on_frame)
    scene.render.resolution_x, scene.render.resolution_y = VIDEO
    scene.display.render_aa = "FXAA"         # one sample a frame: five times faster than the default
    settings = scene.render.image_settings
    if hasattr(settings, "media_type"):       # Blender 5.0: image, multilayer or video
        settings.media_type = "VIDEO"
    settings.file_format = "FFMPEG"
    ff = scene.render.ffmpeg
    ff.format, ff.codec = "MPEG4", "H264"
    ff.constant_rate_factor = "MEDIUM"
    ff.audio_codec, ff.audio_channels, ff.audio_mixrate = "AAC", "MONO", 44100
    scene.render.filepath = path
    try:
        with _quiet():
            bpy.ops.render.render(animation=True)
    finally:
        if label is not None:
            bpy.app.handlers.frame_change_pre.remove(on_frame)
    return os.path.isfile(path)


def main(argv):
    blend_only = "--blend-only" in argv
    argv = [a for a in argv if a != "--blend-only"]
    out_dir = os.path.abspath(argv[0] if argv else os.path.join(ROOT, "out"))
    os.makedirs(out_dir, exist_ok=True)
    sys.path.insert(0, ROOT)
    sys.path.insert(0, HERE)
    import addon
    import sound_strips
    from addon.blender import command, compat, sources
    from addon.engine.alignment import align_audio

    t0 = time.perf_counter()
    heads, label = build_scene()
    bpy.context.preferences.filepaths.save_version = 0   # no sample.blend1 beside the file
    addon.register()
    scene = bpy.context.scene
    text = bpy.data.texts.new("hello.txt")
    with open(os.path.splitext(SPEECH)[0] + ".txt", encoding="utf-8") as fh:
        transcript = fh.read()
    text.from_string(transcript)
    # Strips named after their meshes: "Generate for All Strips" and the
    # command line find the face by the name.
    strips = {name: sound_strips.add(compat, scene, f"{name}_hello", SPEECH, 1, k + 1)
              for k, name in enumerate(heads)}
    for s in strips.values():
        s["lipsync_text"] = text.name
    strips["HumanRPM"].volume = 0.0   # the same line: heard once
    scene.frame_start, scene.frame_end = 1, max(s.frame_final_end for s in strips.values())
    blend = os.path.join(out_dir, "sample.blend")
    if bpy.ops.emotive_lipsync.generate(strip="Human_hello", mesh="Human") != {"FINISHED"}:
        return 1
    status = command.execute(["--strip", "HumanRPM_hello", "--output", blend])
    if status:
        return status
    for obj in heads.values():
        print(f"{obj.name}: {obj.emotive_lipsync.convention}")
    if blend_only:
        print(f"wrote {blend} (Blender {bpy.app.version_string})")
        return 0

    audio = sources.decode(SPEECH)
    alignment = align_audio(audio, transcript)
    tiles = []
    for frame, text_ in chosen_frames(scene, alignment, 1, heads["Human"]):
        scene.frame_set(frame)
        label.data.body = text_
        tiles.append(render_pixels(scene))
    label.data.body = ""
    sheet = os.path.join(out_dir, "sample_contact_sheet.png")
    save_sheet(tiles, sheet)
    print(f"wrote {blend} (Blender {bpy.app.version_string})")
    print(f"wrote {sheet} ({len(tiles)} labelled frames)")
    took = emotions_sheet(scene, heads, label, audio, alignment, transcript,
                          os.path.join(out_dir, "sample_emotions.png"))
    print(f"emotions sheet took {took:.1f} s")
    video = os.path.join(out_dir, "sample.mp4")
    if write_video(scene, video, phone_labels(alignment, 1, scene.render.fps / scene.render.fps_base), label):
        print(f"wrote {video} (frames {scene.frame_start}-{scene.frame_end}, with sound)")
    else:
        print("no video: this Blender has no FFmpeg")
    print(f"demo took {time.perf_counter() - t0:.1f} s")
    return 0


def _unregister():
    """The add-on unregistered, as Blender does on quitting: PyPI's bpy 4.5
    crashes while Python shuts down if it is still registered."""
    addon = sys.modules.get("addon")
    if addon is not None and hasattr(bpy.types.Scene, "emotive_lipsync"):
        addon.unregister()


if __name__ == "__main__":
    try:
        status = main(sys.argv[1:])
    finally:
        _unregister()
    if not bpy.app.binary_path and bpy.app.version < (4, 4, 0):
        # PyPI's bpy 4.2 and 4.3 crash while Python shuts down once any
        # add-on was registered, even unregistered (see tests/blender/conftest.py).
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(status)
    sys.exit(status)
