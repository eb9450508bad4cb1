"""The user's presets: whatever name or path the preset operators are given,
a problem is reported in a sentence naming it and nothing changes; a preset
saved in the panel is found by every way of naming a preset, the command
line's included."""

from __future__ import annotations

import json
import os
import pathlib
import re
from importlib import import_module

import bpy
import numpy as np
import pytest

from conftest import FIXTURES, MODULE, add_strip, fcurve_values, keyed_shape_keys

BOB = os.path.join(FIXTURES, "bob_map.wav")

#: Python's own error texts: none may reach a user.
RAW = re.compile(r"Traceback|unpack|unhashable|has no attribute|NoneType|Errno|not subscriptable|invalid literal|"
                 r"object is not|item assignment|TypeError|ValueError|KeyError|OSError|IndexError")


def _mod(name):
    return import_module(MODULE + ".blender." + name)


def _folder():
    return _mod("userdata").folder(create=True)


@pytest.fixture(autouse=True)
def no_user_presets(scene):
    """Each test starts and ends with no preset of the user's."""
    for f in os.listdir(_folder()):
        os.remove(os.path.join(_folder(), f))
    yield
    for f in os.listdir(_folder()):
        os.remove(os.path.join(_folder(), f))


def _state(scene):
    """Everything a preset operator could change: the panel's preset
    settings and the user's presets folder, file by file."""
    folder = _folder()
    files = {f: open(os.path.join(folder, f), "rb").read() for f in sorted(os.listdir(folder))}
    return _mod("jobs").snapshot(scene.emotive_lipsync), files


def _refused(scene, op, **kw) -> str:
    """Run the preset operator ``op``; it must cancel with one sentence and
    change nothing.  Returns the sentence."""
    before = _state(scene)
    with pytest.raises(RuntimeError) as err:
        getattr(bpy.ops.emotive_lipsync, op)(**kw)
    text = str(err.value)
    assert text.startswith("Error: ") and text.count("\n") == 1, text
    msg = text[len("Error: "):].strip()
    assert not RAW.search(msg), msg
    assert len(msg.split()) >= 4, msg
    assert _state(scene) == before
    return msg


@pytest.fixture
def files(tmp_path):
    """Preset files that are not presets, by what is wrong with them."""
    def put(name, body):
        path = tmp_path / name
        if isinstance(body, bytes):
            path.write_bytes(body)
        else:
            path.write_text(body if isinstance(body, str) else json.dumps(body), encoding="utf-8")
        return str(path)

    (tmp_path / "folder.json").mkdir()
    out = {
        "folder": str(tmp_path),
        "folder_json": str(tmp_path / "folder.json"),
        "missing": str(tmp_path / "missing.json"),
        "not_json": put("notes.txt", "angry, but quietly\n"),
        "list": put("list.json", [1, 2, 3]),
        "broken": put("broken.json", '{"gain": 0.5,'),
        "binary": put("binary.json", b"\xff\xfe\x00\x01"),
        "gain_text": put("gain_text.json", {"gain": "loud"}),
        "rules_number": put("rules_number.json", {"rules": 5}),
        "range_two": put("range_two.json", {"weights": {"range_scale": {"vowel": [1, 2]}}}),
        "phones_lists": put("phones_lists.json", {"rules": {"deletion": {"phones": [["AA"]], "threshold": 0.02}}}),
        "name_list": put("name_list.json", {"name": ["x"]}),
        "bad_base": put("bad_base.json", {"base": "nothing_like_this"}),
        "base_list": put("base_list.json", {"base": ["sad", "angry"]}),
    }
    return out


LOAD_CASES = [
    ("", "no preset given"),
    ("   ", "no preset given"),
    ("..", "is not a preset"),
    ("my.mood", "is not a preset"),
    ("grüße", "is not a preset"),
    ("x" * 300, "is not a preset"),
    ("//relative.json", "not been saved yet"),
    ("{folder}", "is a folder"),
    ("{folder_json}", "is a folder"),
    ("{missing}", "does not exist"),
    ("{folder}/../nowhere/x.json", "does not exist"),
    ("{not_json}", "not valid JSON"),
    ("{list}", "must be a JSON object"),
    ("{broken}", "not valid JSON: line 1"),
    ("{binary}", "not UTF-8"),
    ("{gain_text}", "'gain' must be a number"),
    ("{rules_number}", "'rules' must be an object"),
    ("{range_two}", "range_scale.vowel' must be three numbers"),
    ("{phones_lists}", "phones|wrong kind"),
    ("{name_list}", "'name' must be text"),
    ("{bad_base}", "'base' names 'nothing_like_this'"),
    ("{base_list}", "'base' must be the name of another preset"),
]


@pytest.mark.parametrize("name, problem", LOAD_CASES, ids=[c[0][:20] or "empty" for c in LOAD_CASES])
def test_loading_a_bad_preset_says_what_is_wrong_and_changes_nothing(scene, files, name, problem):
    assert bpy.ops.emotive_lipsync.preset_load(name="sad") == {"FINISHED"}
    msg = _refused(scene, "preset_load", name=name.format(**files))
    assert re.search(problem, msg), msg
    assert scene.emotive_lipsync.emotion == "sad"


def test_a_missing_or_unreadable_preset_file_is_named_and_nothing_changes(scene, tmp_path, monkeypatch):
    assert bpy.ops.emotive_lipsync.preset_load(name="sad") == {"FINISHED"}
    missing = tmp_path / "gone" / "mood.json"
    assert _refused(scene, "preset_load", name=str(missing)) == f"the preset file {missing} does not exist"
    # Files this user may not read (simulated: the tests may run as root, who reads everything).
    locked, hidden = tmp_path / "locked.json", tmp_path / "private" / "mood.json"
    locked.write_text('{"gain": 0.5}', encoding="utf-8")
    read_text, stat = pathlib.Path.read_text, os.stat

    def refuse_read(path, *args, **kwargs):
        if path == locked:
            raise PermissionError(13, "Permission denied", str(path))
        return read_text(path, *args, **kwargs)

    def refuse_look(path, *args, **kwargs):
        if os.fspath(path) == str(hidden):
            raise PermissionError(13, "Permission denied", os.fspath(path))
        return stat(path, *args, **kwargs)

    monkeypatch.setattr(pathlib.Path, "read_text", refuse_read)
    monkeypatch.setattr(os, "stat", refuse_look)
    msg = _refused(scene, "preset_load", name=str(locked))
    assert str(locked) in msg and "cannot be read: Permission denied" in msg, msg
    msg = _refused(scene, "preset_load", name=str(hidden))
    assert msg == f"cannot read the preset file {hidden}: Permission denied", msg
    # A name that is no regular file.
    pipe = tmp_path / "pipe.json"
    os.mkfifo(pipe)
    msg = _refused(scene, "preset_load", name=str(pipe))
    assert msg == f"{pipe} is not a file but a device, a pipe or a socket: give a .json preset file", msg
    assert scene.emotive_lipsync.emotion == "sad"


SAVE_CASES = [
    ("", "needs a name"),
    ("   ", "needs a name"),
    ("\t", "needs a name"),
    (".", "starts with a dot"),
    ("..", "starts with a dot"),
    ("../evil", "holds one of the characters"),
    ("/tmp/evil", "holds one of the characters"),
    ("a/b", "holds one of the characters"),
    ("C:\\evil", "holds one of the characters"),
    ("what?", "holds one of the characters"),
    ("two\nlines", "control character"),
    ("mood.json", "ends in .json"),
    ("con", "Windows keeps for a device"),
    ("nul.mood", "Windows keeps for a device"),
    ("x" * 300, "longer than 200 bytes"),
    ("sad", "is a built-in preset"),
    (" angry ", "is a built-in preset"),
]


@pytest.mark.parametrize("name, problem", SAVE_CASES, ids=[repr(c[0][:12]) for c in SAVE_CASES])
def test_saving_under_a_bad_name_says_why_and_writes_nothing(scene, name, problem):
    assert bpy.ops.emotive_lipsync.preset_load(name="happy") == {"FINISHED"}
    msg = _refused(scene, "preset_add", name=name)
    assert problem in msg, msg


def test_a_broken_preset_of_the_users_is_named_by_its_file(scene):
    """A saved preset edited by hand into something that is no preset."""
    for name, body, problem in (("list", "[1, 2]", "must be a JSON object"),
                                ("cut", '{"gain": 0.5,', "not valid JSON: line 1"),
                                ("typed", '{"gain": [1, 2]}', "'gain' must be a number"),
                                ("odd.name", '{"rules": {"apex": "middle"}}', "'rules.apex' must be a number")):
        path = os.path.join(_folder(), name + ".json")
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(body)
        msg = _refused(scene, "preset_load", name=name)
        assert path in msg and problem in msg, msg
    assert _mod("userdata").preset_names() == ["cut", "list", "odd.name", "typed"]


def test_saving_over_a_preset_needs_overwrite_and_broken_panel_numbers_save_nothing(scene):
    st = scene.emotive_lipsync
    assert bpy.ops.emotive_lipsync.preset_load(name="happy") == {"FINISHED"}
    assert bpy.ops.emotive_lipsync.preset_add(name="cheery") == {"FINISHED"}
    assert "exists: tick Overwrite" in _refused(scene, "preset_add", name="cheery")
    assert bpy.ops.emotive_lipsync.preset_add(name="cheery", overwrite=True) == {"FINISHED"}
    # Numbers edited in the panel that no longer make a preset.
    triple = next(v for v in st.preset_values if v.kind == "TRIPLE")
    triple.kind, triple.text = "LIST", "1 2"
    assert f"'{triple.path}' must be three numbers" in _refused(scene, "preset_add", name="cheerier")
    triple.kind = "TRIPLE"
    source = next(v for v in st.preset_values if v.path == "weights.other_source")
    source.text = "loudness"
    assert "other_source' must be intensity, pitch, both or neutral" in _refused(scene, "preset_add", name="x")
    # The panel holding no numbers and naming something that is no preset.
    st.preset_values.clear()
    st.emotion = "../gone"
    assert "does not exist" in _refused(scene, "preset_add", name="x")


def test_names_with_dots_spaces_and_accents_are_saved_and_found(scene):
    st = scene.emotive_lipsync
    for typed, name in (("  calm  ", "calm"), ("v1.2 mood", "v1.2 mood"), ("grüße", "grüße")):
        assert bpy.ops.emotive_lipsync.preset_load(name="sad") == {"FINISHED"}
        assert bpy.ops.emotive_lipsync.preset_add(name=typed) == {"FINISHED"}
        assert st.emotion == name and os.path.isfile(os.path.join(_folder(), name + ".json"))
        assert bpy.ops.emotive_lipsync.preset_load(name="neutral") == {"FINISHED"}
        assert bpy.ops.emotive_lipsync.preset_load(name=name) == {"FINISHED"}
        assert st.emotion == name
    assert _mod("userdata").preset_names() == ["calm", "grüße", "v1.2 mood"]


def test_deleting_touches_only_the_users_own_presets(scene, tmp_path):
    st = scene.emotive_lipsync
    victim = tmp_path / "victim.json"
    victim.write_text(json.dumps({"gain": 0.5}), encoding="utf-8")
    outside = os.path.join(os.path.dirname(_folder()), "outside.json")   # beside the presets folder
    with open(outside, "w", encoding="utf-8") as fh:
        json.dump({"gain": 0.5}, fh)
    for emotion, problem in (("", "is not one of your presets"), ("..", "is not one of your presets"),
                             ("../outside", "is not one of your presets"),
                             (str(victim), "is not one of your presets"),
                             (str(victim)[:-5], "is not one of your presets"),
                             ("sad", "built-in presets cannot be deleted"),
                             ("ghost", "is not one of your presets")):
        st.emotion = emotion
        assert problem in _refused(scene, "preset_add", remove_active=True), emotion
    assert victim.is_file() and os.path.isfile(outside)
    os.remove(outside)
    # One of yours: its file goes, with the training report a learned preset has beside it.
    for f, body in (("mine.json", {"gain": 0.5}), ("mine.report.json", {"clips": {}})):
        with open(os.path.join(_folder(), f), "w", encoding="utf-8") as fh:
            json.dump(body, fh)
    assert _mod("userdata").preset_names() == ["mine"]
    st.emotion = "mine"
    assert bpy.ops.emotive_lipsync.preset_add(remove_active=True) == {"FINISHED"}
    assert os.listdir(_folder()) == [] and st.emotion == "neutral"


def test_learned_poses_on_dotted_shape_keys_survive_the_panel(scene, tmp_path):
    """A learned preset's poses name shape keys, and Blender's names hold
    dots (``mouth.L``): the panel keeps them whole."""
    targets = {"AA": {"jaw.open": 1.0}, "MBP": {"lips": 0.2, "lips.L": 0.5, "lips.R": 0.5}}
    path = tmp_path / "dotty.json"
    path.write_text(json.dumps({"name": "dotty", "learned": {"viseme_set": "default", "targets": targets}}),
                    encoding="utf-8")
    assert bpy.ops.emotive_lipsync.preset_load(name=str(path)) == {"FINISHED"}
    assert bpy.ops.emotive_lipsync.preset_add(name="dotty copy") == {"FINISHED"}
    with open(os.path.join(_folder(), "dotty copy.json"), encoding="utf-8") as fh:
        saved = json.load(fh)
    assert saved["learned"]["targets"] == targets
    assert _mod("userdata").panel_preset(scene.emotive_lipsync).learned.targets == targets


def _keys(obj):
    return {k: fcurve_values(obj, k) for k in sorted(keyed_shape_keys(obj))}


def test_command_line_emotion_finds_a_preset_saved_in_the_panel(scene, capsys):
    """``--command lipsync --emotion NAME`` reads the preset the panel saved
    under NAME, exactly as the Generate operator does."""
    st = scene.emotive_lipsync
    assert bpy.ops.emotive_lipsync.preset_load(name="sad") == {"FINISHED"}
    next(v for v in st.preset_values if v.path == "gain").number = 0.4
    assert bpy.ops.emotive_lipsync.preset_add(name="mumbly") == {"FINISHED"}
    assert bpy.ops.emotive_lipsync.preset_load(name="angry") == {"FINISHED"}   # the panel moves on
    add_strip(scene, "line", BOB, frame=1)
    ada = bpy.data.objects["Ada"]
    assert bpy.ops.emotive_lipsync.generate(mesh="Ada", strip="line", emotion="mumbly", tolerance=0.0) == \
        {"FINISHED"}
    by_operator = _keys(ada)
    assert bpy.ops.emotive_lipsync.generate(mesh="Ada", strip="line", tolerance=0.0) == {"FINISHED"}
    angry = _keys(ada)
    assert _mod("command").execute(["--strip", "line", "--mesh", "Ada", "--emotion", "mumbly",
                                    "--tolerance", "0"]) == 0
    by_command = _keys(ada)
    assert by_command.keys() == by_operator.keys()
    for k, (frames, values) in by_operator.items():
        assert np.array_equal(by_command[k][0], frames) and np.allclose(by_command[k][1], values, atol=1e-6), k
    assert any(not np.allclose(angry[k][1], v) for k, (_f, v) in by_operator.items())
    # A name that is neither: the same sentence as the panel's, exit status 1.
    assert _mod("command").execute(["--strip", "line", "--mesh", "Ada", "--emotion", "grumpy"]) == 1
    err = capsys.readouterr().err
    assert "'grumpy' is not a preset" in err and "yours: mumbly" in err
