"""An animator's polish kept over Generate (issue #47): a hand-raised key
stays raised over another preset, moves with its sound to a later take, is
dropped (and reported) with a word gone from the transcript; a locked range
of frames keeps its keys; discarding gives the fresh curve; Clear, Bake and
undo; the glTF export; bone rigs (pose assets and properties); the batch
command and its manifests.

Most of it runs on the human sample head (``sample_rigs/human.py``, ARKit
keys) with the shipped line, keyed from frame :data:`START` at 30 fps.  A
fresh curve to compare with is made by Clear and Generate, so a test fails
if a run left anything of the edits where they do not belong."""

from __future__ import annotations

import os
import wave
from types import SimpleNamespace
from importlib import import_module
from pathlib import Path

import bpy
import numpy as np
import pytest

from conftest import FIXTURES, MODULE, SAMPLE, add_strip

START = 5
FPS = 30
TEXT = Path(SAMPLE).with_suffix(".txt").read_text(encoding="utf-8").strip()
BOB = os.path.join(FIXTURES, "bob_map.wav")
BOB_TEXT = "Bob bought a map."
JAW = 'key_blocks["jawOpen"].value'


def _mod(name):
    return import_module(f"{MODULE}.{name}")


@pytest.fixture(scope="module")
def human(extension):
    import human as module

    module.assets()
    return module


@pytest.fixture(scope="module")
def sample_audio(extension):
    """The shipped line as Blender decodes it, and its alignment."""
    audio = _mod("blender.sources").decode(SAMPLE)
    return audio, _mod("engine.pipeline").align_audio(audio, TEXT)


@pytest.fixture
def head(extension, human):
    """An empty 30 fps scene with the human head (ARKit keys) and the line on a strip from START."""
    bpy.ops.wm.read_homefile(use_empty=True)
    sc = bpy.context.scene
    sc.render.fps, sc.render.fps_base = FPS, 1.0
    obj = human.build("Head", "arkit")
    add_strip(sc, "line", SAMPLE, frame=START)
    return sc, obj


def _write_wav(path, audio, before=0.0, cut=None):
    """``audio`` as a 16-bit WAV file, ``before`` s of silence put in front
    and the stretch ``cut`` (start, end s) taken out."""
    x = np.asarray(audio.samples, dtype=np.float64)
    if cut is not None:
        a, b = int(cut[0] * audio.rate), int(cut[1] * audio.rate)
        x = np.concatenate([x[:a], x[b:]])
    x = np.concatenate([np.zeros(int(round(before * audio.rate))), x])
    with wave.open(str(path), "wb") as fh:
        fh.setnchannels(1)
        fh.setsampwidth(2)
        fh.setframerate(audio.rate)
        fh.writeframes((np.clip(x, -1, 1) * 32767).astype("<i2").tobytes())
    return str(path)


def _generate(obj, **kw):
    kw.setdefault("text", TEXT)
    return bpy.ops.emotive_lipsync.generate("EXEC_DEFAULT", mesh=obj.name, **kw)


def _fcurve(obj, path=JAW, index=0):
    owner = obj if obj.type == "ARMATURE" else obj.data.shape_keys
    return _mod("blender.compat").find_fcurve(owner, path, index)


def _values(obj, frames, path=JAW, index=0):
    fc = _fcurve(obj, path, index)
    return np.array([fc.evaluate(f) for f in frames])


def _keys(obj, path=JAW, index=0):
    fc = _fcurve(obj, path, index)
    return [(tuple(k.co), tuple(k.handle_left), tuple(k.handle_right), k.interpolation)
            for k in fc.keyframe_points]


def _raise(obj, by=0.25, path=JAW, index=0, within=None):
    """Raise the highest key of the curve (inside the frames ``within``) by
    ``by``, as in the Graph Editor; its frame."""
    fc = _fcurve(obj, path, index)
    keys = [k for k in fc.keyframe_points if within is None or within[0] <= k.co[0] <= within[1]]
    k = max(keys, key=lambda k: k.co[1])
    for attr in ("co", "handle_left", "handle_right"):
        getattr(k, attr)[1] += by
    fc.update()
    return int(round(k.co[0]))


def _fresh(obj, **kw):
    """The curve a Generate on the untouched target gives: Clear, then Generate."""
    assert bpy.ops.emotive_lipsync.clear("EXEC_DEFAULT", mesh=obj.name) == {"FINISHED"}
    assert _generate(obj, **kw) == {"FINISHED"}


def _reports(capsys) -> str:
    return capsys.readouterr().out + capsys.readouterr().err


def _summary(monkeypatch):
    """The Summary of each run from here on (its message is the operator's report)."""
    run = _mod("blender.run")
    seen = []
    real = run.key

    def key(*a, **kw):
        seen.append(real(*a, **kw))
        return seen[-1]

    monkeypatch.setattr(run, "key", key)
    return seen


def _line_frames(sample_audio):
    audio, _al = sample_audio
    return np.arange(START, START + int(np.ceil(audio.duration * FPS)) + 1)


# --- the sample head --------------------------------------------------------------------

def test_an_edit_survives_another_preset_and_discard_gives_the_fresh_curve(head, sample_audio, monkeypatch):
    _sc, obj = head
    runs = _summary(monkeypatch)
    frames = _line_frames(sample_audio)
    assert _generate(obj) == {"FINISHED"}
    assert runs[-1].edits == ""
    at = _raise(obj)
    assert _generate(obj, emotion="angry") == {"FINISHED"}
    assert runs[-1].edits == "hand edits: 1 kept"
    assert "; hand edits: 1 kept" in runs[-1].message()
    kept = _values(obj, frames)
    assert _generate(obj, emotion="angry", hand_edits="discard") == {"FINISHED"}
    assert runs[-1].edits == "hand edits: 1 discarded"
    discarded = _values(obj, frames)
    _fresh(obj, emotion="angry")
    fresh = _values(obj, frames)
    np.testing.assert_allclose(discarded, fresh, atol=1e-6)
    diff = kept - fresh
    row = at - START
    assert diff[row] == pytest.approx(0.25, abs=1e-4)
    diff[row] = 0
    assert np.abs(diff).max() <= 1e-4
    # The angry curve is another curve: the raise is on it, not a copy of the old one.
    assert np.abs(fresh - _values_of_neutral(obj, frames)).max() > 0.05


def _values_of_neutral(obj, frames):
    _fresh(obj)
    return _values(obj, frames)


def test_an_edit_moves_with_its_sound_to_a_take_03_s_later(head, sample_audio, tmp_path, monkeypatch):
    sc, obj = head
    runs = _summary(monkeypatch)
    audio, _al = sample_audio
    assert _generate(obj) == {"FINISHED"}
    at = _raise(obj)
    later = _write_wav(tmp_path / "take2.wav", audio, before=0.3)
    # The new take on a strip of its own, where the old one was.
    seq = sc.sequence_editor
    strips = getattr(seq, "strips", None) or seq.sequences
    strips.remove(strips["line"])
    add_strip(sc, "take2", later, frame=START)
    frames = np.arange(START, START + int(np.ceil((audio.duration + 0.3) * FPS)) + 1)
    assert _generate(obj, strip="take2") == {"FINISHED"}
    assert runs[-1].edits == "hand edits: 1 moved with their sound"
    carried = _values(obj, frames)
    _fresh(obj, strip="take2")
    diff = carried - _values(obj, frames)
    moved = at + 9 - START                      # 0.3 s at 30 fps
    assert diff[moved] == pytest.approx(0.25, abs=0.06)
    far = np.abs(frames - (at + 9)) > 0.25 * FPS
    assert np.abs(diff[far]).max() <= 0.03
    assert np.abs(diff).max() == pytest.approx(diff[moved])


def test_an_edit_moves_with_its_strip_and_the_frames_it_left_lose_their_keys(head, sample_audio, monkeypatch):
    sc, obj = head
    runs = _summary(monkeypatch)
    audio, _al = sample_audio
    assert _generate(obj) == {"FINISHED"}
    at = _raise(obj)
    strip = _mod("blender.compat").all_strips(sc)[0]
    moved = "content_start" if hasattr(strip, "left_handle") else "frame_start"   # renamed in 5.1
    setattr(strip, moved, getattr(strip, moved) + 9)
    frames = np.arange(START, START + int(np.ceil(audio.duration * FPS)) + 10)
    assert _generate(obj) == {"FINISHED"}
    assert runs[-1].edits == "hand edits: 1 moved with their sound"
    assert min(k[0][0] for k in _keys(obj)) == START + 9      # the old line's first frames are not keyed
    carried = _values(obj, frames)
    _fresh(obj)
    diff = carried - _values(obj, frames)
    assert diff[at + 9 - START] == pytest.approx(0.25, abs=1e-4)
    diff[at + 9 - START] = 0
    assert np.abs(diff).max() <= 1e-4


def test_an_edit_on_a_word_gone_from_the_transcript_is_dropped_and_reported(head, sample_audio, tmp_path,
                                                                            monkeypatch):
    sc, obj = head
    runs = _summary(monkeypatch)
    audio, al = sample_audio
    words = [w for w in al.words if w.spoken]
    k = next(i for i, w in enumerate(words) if w.text.lower() == "very")
    very, after = words[k], words[k + 1]
    assert _generate(obj) == {"FINISHED"}
    on_very = _raise(obj, within=(START + very.start * FPS + 1, START + very.end * FPS - 1))
    on_happy = _raise(obj, within=(START + after.start * FPS + 1, START + after.end * FPS - 1))
    cut = after.start - very.start
    take = _write_wav(tmp_path / "no_very.wav", audio, cut=(very.start, after.start))
    text = TEXT.replace("very ", "")
    assert text != TEXT
    assert _generate(obj, filepath=take, frame=START, text=text) == {"FINISHED"}
    said = runs[-1].edits
    assert said.startswith("hand edits: 1 moved with their sound, 1 dropped (")
    assert f"jawOpen at frame {on_very}: on 'very', which the new line does not say" in said
    frames = np.arange(START, START + int(np.ceil(audio.duration * FPS)) + 1)
    carried = _values(obj, frames)
    _fresh(obj, filepath=take, frame=START, text=text)
    diff = carried - _values(obj, frames)
    # The edit on "happy" moved back by the cut's length; nothing else is left of the edits.
    moved = int(np.argmax(diff))
    assert diff[moved] == pytest.approx(0.25, abs=0.06)
    assert abs(frames[moved] - (on_happy - cut * FPS)) <= 1.5
    diff[max(0, moved - 1):moved + 2] = 0
    assert np.abs(diff).max() <= 0.03


@pytest.mark.parametrize("tolerance", [0.0, 0.02])
def test_a_locked_range_keeps_its_keys_and_the_rest_is_keyed_afresh(head, sample_audio, tolerance, monkeypatch):
    _sc, obj = head
    runs = _summary(monkeypatch)
    frames = _line_frames(sample_audio)
    assert _generate(obj, tolerance=tolerance) == {"FINISHED"}
    at = _raise(obj)
    lock = (at - 6, at + 7)
    inside = (frames >= lock[0]) & (frames <= lock[1])
    fine = np.arange(lock[0], lock[1] + 0.01, 0.25)
    before_keys = [k for k in _keys(obj) if lock[0] <= k[0][0] <= lock[1]]
    before = {name: _values(obj, fine, f'key_blocks["{name}"].value') for name in ("jawOpen", "mouthClose")}
    assert _generate(obj, emotion="angry", tolerance=tolerance, lock=f"{lock[0]}-{lock[1]}") == {"FINISHED"}
    assert runs[-1].edits == \
        f"hand edits: 1 in the locked frames; frames {lock[0]}-{lock[1]} locked (left as they were)"
    after_keys = [k for k in _keys(obj) if lock[0] <= k[0][0] <= lock[1]]
    if tolerance == 0:
        assert after_keys == before_keys       # the animator's keys themselves
    else:   # the same keys, and at most one at each edge, made where a segment crossed it
        assert {k[0] for k in before_keys} <= {k[0] for k in after_keys}
        assert len(after_keys) <= len(before_keys) + 2
    for name, values in before.items():        # every frame and between them draws as before
        np.testing.assert_allclose(_values(obj, fine, f'key_blocks["{name}"].value'), values, atol=1e-5)
    locked = _values(obj, frames)
    _fresh(obj, emotion="angry", tolerance=tolerance)
    fresh = _values(obj, frames)
    np.testing.assert_allclose(locked[~inside], fresh[~inside], atol=tolerance + 1e-4)
    assert np.abs(locked[inside] - fresh[inside]).max() > 0.05


def test_a_lock_reaching_before_the_line_leaves_the_keys_there_alone(scene, monkeypatch):
    runs = _summary(monkeypatch)
    kit = bpy.data.objects["Kit"]
    add_strip(scene, "line", BOB, frame=START + 10)
    assert _generate(kit, text=BOB_TEXT) == {"FINISHED"}
    fc = _fcurve(kit)
    for frame, value in ((1, 0.3), (4, 0.6), (8, 0.1)):     # the animator's own keys before the line
        fc.keyframe_points.insert(frame, value).interpolation = "BEZIER"
    before = _keys(kit)
    fine = np.arange(1, START + 17.01, 0.25)
    drawn = _values(kit, fine)
    assert _generate(kit, text=BOB_TEXT, emotion="angry", lock=f"0-{START + 17}") == {"FINISHED"}
    assert runs[-1].edits == f"frames 0-{START + 17} locked (left as they were)"
    after = _keys(kit)
    assert [k for k in after if k[0][0] < START + 17] == [k for k in before if k[0][0] < START + 17]
    np.testing.assert_allclose(_values(kit, fine), drawn, atol=1e-5)


def test_clear_removes_the_keys_and_the_edits_and_undo_brings_both_back(head, monkeypatch):
    _sc, obj = head
    runs = _summary(monkeypatch)
    edits = _mod("blender.edits")
    assert _generate(obj) == {"FINISHED"}
    at = _raise(obj)
    raised = _keys(obj)
    assert edits.remembered(obj) == 1
    bpy.ops.ed.undo_push(message="before clear")
    assert bpy.ops.emotive_lipsync.clear("EXEC_DEFAULT", True, mesh=obj.name) == {"FINISHED"}
    obj = bpy.data.objects["Head"]
    assert _fcurve(obj) is None and edits.remembered(obj) == 0
    assert not _mod("blender.keying").lipsynced(obj)
    bpy.ops.ed.undo()
    obj = bpy.data.objects["Head"]
    assert _keys(obj) == raised and edits.remembered(obj) == 1
    # ... and the edit is still known as one: Generate keeps it.
    assert _generate(obj, emotion="sad") == {"FINISHED"}
    assert runs[-1].edits == "hand edits: 1 kept"
    # Undo takes a Generate back, edits and remembered curves with it.
    bpy.ops.ed.undo_push(message="before discard")
    assert bpy.ops.emotive_lipsync.generate("EXEC_DEFAULT", True, mesh=obj.name, text=TEXT,
                                            hand_edits="discard") == {"FINISHED"}
    bpy.ops.ed.undo()
    obj = bpy.data.objects["Head"]
    assert _generate(obj) == {"FINISHED"}
    assert runs[-1].edits == "hand edits: 1 kept"
    assert _values(obj, [at]) - _values_after_fresh(obj, at) == pytest.approx(0.25, abs=1e-4)


def _values_after_fresh(obj, at):
    _fresh(obj)
    return _values(obj, [at])


def test_bake_makes_plain_keys_with_the_edits_in_them(head, monkeypatch):
    _sc, obj = head
    runs = _summary(monkeypatch)
    edits, keying = _mod("blender.edits"), _mod("blender.keying")
    assert _generate(obj) == {"FINISHED"}
    _raise(obj)
    assert _generate(obj, emotion="happy") == {"FINISHED"}
    keyed = _keys(obj)
    bpy.ops.ed.undo_push(message="before bake")
    assert bpy.ops.emotive_lipsync.bake("EXEC_DEFAULT", True, mesh=obj.name) == {"FINISHED"}
    obj = bpy.data.objects["Head"]
    assert _keys(obj) == keyed
    assert edits.remembered(obj) == 0 and not keying.lipsynced(obj)
    # Plain keys: Clear has nothing of the add-on's to remove, and they stay.
    assert bpy.ops.emotive_lipsync.clear("EXEC_DEFAULT", mesh=obj.name) == {"CANCELLED"}
    assert _keys(obj) == keyed
    with pytest.raises(RuntimeError, match="no lip sync made by this add-on to bake"):
        bpy.ops.emotive_lipsync.bake("EXEC_DEFAULT", mesh=obj.name)
    bpy.ops.ed.undo()
    obj = bpy.data.objects["Head"]
    assert edits.remembered(obj) == 1 and keying.lipsynced(obj)
    assert _generate(obj) == {"FINISHED"}
    assert runs[-1].edits == "hand edits: 1 kept"


def test_bad_hand_edit_options_are_refused_before_anything_is_keyed(head):
    _sc, obj = head
    with pytest.raises(RuntimeError, match="hand edits 'maybe': give keep or discard"):
        _generate(obj, hand_edits="maybe")
    with pytest.raises(RuntimeError, match="the locked frames 40-20 end before they start"):
        _generate(obj, lock="40-20")
    with pytest.raises(RuntimeError, match=r"locked frames 'soon': give FIRST-LAST"):
        _generate(obj, lock="soon")
    assert _fcurve(obj) is None
    assert _mod("blender.edits").parse_lock("-10--2") == (-10, -2)
    assert _mod("blender.edits").parse_lock(" none ") is None


def test_the_panel_settings_choose_discard_and_the_lock(head, sample_audio, monkeypatch):
    sc, obj = head
    runs = _summary(monkeypatch)
    st = sc.emotive_lipsync
    assert _generate(obj) == {"FINISHED"}
    at = _raise(obj)
    st.lock_frames, st.lock_first, st.lock_last = True, at - 2, at + 2
    assert _generate(obj, emotion="angry") == {"FINISHED"}
    assert runs[-1].edits.endswith(f"frames {at - 2}-{at + 2} locked (left as they were)")
    st.lock_frames = False
    st.hand_edits = "DISCARD"
    assert _generate(obj, emotion="angry") == {"FINISHED"}
    assert runs[-1].edits == "hand edits: 1 discarded"
    # The operator's own choice wins over the panel's.
    _raise(obj)
    assert _generate(obj, hand_edits="keep") == {"FINISHED"}
    assert runs[-1].edits == "hand edits: 1 kept"
    # The panel's Hand Edits part draws the settings and the Bake button.
    st.target = obj
    layout = _Layout()
    _mod("blender.edits_ui").LIPSYNC_PT_edits.draw(SimpleNamespace(layout=layout), bpy.context)
    assert {"hand_edits", "lock_frames", "lock_first", "lock_last"} <= set(layout.props)
    assert layout.operators == ["emotive_lipsync.bake"]
    assert "Head: 1 line remembered" in layout.labels


class _Layout:
    """A stand-in for a panel's layout: records what is drawn, and checks
    that each property drawn exists."""

    def __init__(self, root=None):
        self.root = root or self
        if root is None:
            self.props, self.operators, self.labels = [], [], []

    def __getattr__(self, name):
        if name in ("row", "column", "box", "split"):
            return lambda *a, **kw: _Layout(self.root)
        raise AttributeError(name)

    def prop(self, data, name, **_kw):
        assert hasattr(data, name), name
        self.root.props.append(name)

    def operator(self, idname, **_kw):
        self.root.operators.append(idname)
        return SimpleNamespace()

    def label(self, text="", **_kw):
        self.root.labels.append(text)


def test_the_expression_layer_keeps_edits_on_its_keys(head, monkeypatch):
    _sc, obj = head
    runs = _summary(monkeypatch)
    assert _generate(obj, emotion="sad") == {"FINISHED"}
    brow = 'key_blocks["browInnerUp"].value'
    assert _fcurve(obj, brow) is not None
    at = _raise(obj, by=-0.2, path=brow)   # a softer brow on its strongest frame
    assert _generate(obj, emotion="sad", coarticulation="rules") == {"FINISHED"}
    assert runs[-1].edits == "hand edits: 1 kept"
    kept = _values(obj, [at - 1, at, at + 1], brow)
    _fresh(obj, emotion="sad", coarticulation="rules")
    np.testing.assert_allclose(kept - _values(obj, [at - 1, at, at + 1], brow), [0, -0.2, 0], atol=1e-4)
    # A run that does not drive the brow (neutral has no expression, and no
    # gestures raise the brows): the edit has no curve to sit on.
    _raise(obj, by=-0.2, path=brow)
    assert _generate(obj, emotion="neutral", no_gestures=True) == {"FINISHED"}
    assert f"browInnerUp at frame {at}: this run does not key browInnerUp" in runs[-1].edits


# --- the glTF export -------------------------------------------------------------------

def test_the_gltf_export_carries_the_edited_curve(scene, tmp_path, monkeypatch):
    from test_gltf import GLTF_EXPORT, _call, _enable, _morph_animation, _read_gltf

    runs = _summary(monkeypatch)
    kit = bpy.data.objects["Kit"]
    add_strip(scene, "line", BOB, frame=START)
    assert _generate(kit, text=BOB_TEXT) == {"FINISHED"}
    at = _raise(kit)
    assert _generate(kit, text=BOB_TEXT, emotion="happy") == {"FINISHED"}
    assert runs[-1].edits == "hand edits: 1 kept"
    frames = np.arange(START, START + 40)
    edited = _values(kit, frames)
    _enable("io_scene_gltf2")
    out = str(tmp_path / "kit.gltf")
    _call(bpy.ops.export_scene.gltf, filepath=out, **GLTF_EXPORT)
    names, times, weights, _interpolation = _morph_animation(*_read_gltf(out), "Kit")
    exported = np.interp(frames / FPS, times, weights[:, names.index("jawOpen")])
    np.testing.assert_allclose(exported, edited, atol=1e-3)
    _fresh(kit, text=BOB_TEXT, emotion="happy")
    assert exported[at - START] - _values(kit, [at])[0] == pytest.approx(0.25, abs=1e-3)


# --- bone rigs ---------------------------------------------------------------------------

JAW_BONE = ('pose.bones["jaw"].rotation_euler', 0)


def test_a_bone_rig_keeps_an_edit_over_another_preset_and_a_later_take(extension, tmp_path, monkeypatch):
    from test_bones import BOB as RIG_LINE
    from test_bones import BOB_TEXT as RIG_TEXT
    from test_bones import FPS as RIG_FPS
    from test_bones import START as RIG_START
    from test_bones import _build_rig

    runs = _summary(monkeypatch)
    sc, rig = _build_rig()
    add_strip(sc, "line", RIG_LINE, frame=RIG_START)
    frames = np.arange(RIG_START, RIG_START + 48)

    def gen(**kw):
        assert bpy.ops.emotive_lipsync.generate("EXEC_DEFAULT", mesh=rig.name, text=RIG_TEXT, **kw) == {"FINISHED"}
        return _values(rig, frames, *JAW_BONE)

    gen()
    at = _raise(rig, path=JAW_BONE[0])
    kept = gen(emotion="angry")
    assert runs[-1].edits == "hand edits: 1 kept"
    _fresh(rig, text=RIG_TEXT, emotion="angry")
    diff = kept - _values(rig, frames, *JAW_BONE)
    assert diff[at - RIG_START] == pytest.approx(0.25, abs=1e-4)
    diff[at - RIG_START] = 0
    assert np.abs(diff).max() <= 1e-4
    # A take 0.3 s later, from an audio file at the strip's frame: the edit follows its sound (7.2 frames at 24 fps).
    at = _raise(rig, path=JAW_BONE[0])
    take = _write_wav(tmp_path / "later.wav", _mod("blender.sources").decode(RIG_LINE), before=0.3)
    moved = gen(filepath=take, frame=RIG_START)
    assert runs[-1].edits == "hand edits: 1 moved with their sound"
    _fresh(rig, text=RIG_TEXT, filepath=take, frame=RIG_START)
    diff = moved - _values(rig, frames, *JAW_BONE)
    row = at + 7 - RIG_START
    assert diff[row] == pytest.approx(0.25, abs=0.06)
    assert np.abs(diff[np.abs(frames - (at + 7)) > 0.25 * RIG_FPS]).max() <= 0.03
    # Clear takes the keys and the remembered curves; the user's brow keys stay.
    assert bpy.ops.emotive_lipsync.clear("EXEC_DEFAULT", mesh=rig.name) == {"FINISHED"}
    assert _fcurve(rig, *JAW_BONE) is None and _mod("blender.edits").remembered(rig) == 0
    assert _fcurve(rig, 'pose.bones["brow"].location', 1) is not None


def test_a_rig_property_keeps_its_edit(extension, monkeypatch):
    from test_bones import BOB as RIG_LINE
    from test_bones import BOB_TEXT as RIG_TEXT
    from test_bones import START as RIG_START
    from test_bones import _build_rig

    runs = _summary(monkeypatch)
    sc, rig = _build_rig(props=True)
    add_strip(sc, "line", RIG_LINE, frame=RIG_START)
    for name in ("viseme_PP", "viseme_aa", "viseme_O", "viseme_sil"):
        rig[name] = 0.0
    path = '["viseme_aa"]'
    frames = np.arange(RIG_START, RIG_START + 48)
    assert bpy.ops.emotive_lipsync.generate("EXEC_DEFAULT", mesh=rig.name, text=RIG_TEXT) == {"FINISHED"}
    at = _raise(rig, by=-0.2, path=path)
    assert bpy.ops.emotive_lipsync.generate("EXEC_DEFAULT", mesh=rig.name, text=RIG_TEXT,
                                            emotion="surprised") == {"FINISHED"}
    assert runs[-1].edits == "hand edits: 1 kept"
    kept = _values(rig, frames, path)
    _fresh(rig, text=RIG_TEXT, emotion="surprised")
    diff = kept - _values(rig, frames, path)
    assert diff[at - RIG_START] == pytest.approx(-0.2, abs=1e-4)
    assert np.count_nonzero(np.abs(diff) > 1e-4) == 1


# --- the batch command -------------------------------------------------------------------

def test_the_command_and_its_manifests_keep_discard_and_lock(scene, tmp_path, capsys):
    command = _mod("blender.command")
    kit = bpy.data.objects["Kit"]
    add_strip(scene, "line", BOB, frame=START)
    frames = np.arange(START, START + 40)
    base = ["--strip", "line", "--mesh", "Kit", "--text", BOB_TEXT]
    assert command.execute(base) == 0
    _raise(kit)
    raised = _values(kit, frames)
    assert command.execute(base + ["--emotion", "angry"]) == 0
    assert "; hand edits: 1 kept" in capsys.readouterr().out
    assert command.execute(base + ["--emotion", "angry", "--edits", "discard"]) == 0
    assert "; hand edits: 1 discarded" in capsys.readouterr().out
    # A manifest line locks frames and keeps edits of its own accord.
    at = _raise(kit)
    manifest = tmp_path / "lines.csv"
    manifest.write_text(f"strip,mesh,text,edits,lock\nline,Kit,{BOB_TEXT},keep,{at - 3}-{at + 3}\n")
    locked = _values(kit, np.arange(at - 3, at + 4))
    assert command.execute(["--manifest", str(manifest)]) == 0
    out = capsys.readouterr().out
    assert f"hand edits: 1 in the locked frames; frames {at - 3}-{at + 3} locked (left as they were)" in out
    np.testing.assert_array_equal(_values(kit, np.arange(at - 3, at + 4)), locked)
    # Bad values: a usage error for the option, a line's problem for the column.
    assert command.execute(base + ["--edits", "maybe"]) == 2
    assert command.execute(base + ["--lock", "9-3"]) == 1
    assert "lipsync: the locked frames 9-3 end before they start" in capsys.readouterr().err
    manifest.write_text(f"strip,mesh,text,edits\nline,Kit,{BOB_TEXT},maybe\n")
    assert command.execute(["--manifest", str(manifest)]) == 1
    assert "lipsync: line 2: hand edits 'maybe': give keep or discard" in capsys.readouterr().err
    assert np.abs(_values(kit, frames) - raised).max() > 0   # it was keyed again meanwhile
