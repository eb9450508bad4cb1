"""A line's settings: built once from plain values, checked then, and
handed down whole (to the pipeline, to a batch's lines, to a Dask worker)."""

import dataclasses
import json

import pytest

from addon.engine import batch, cli, presets
from addon.engine.alignment import AlignSettings
from addon.engine.errors import LipSyncError, PresetError, SettingError
from addon.engine.settings import LineSettings


def test_plain_values_become_typed_settings():
    s = LineSettings.of("happy", viseme_set="arkit", fps="29.97", coarticulation="rules", language="de",
                        emotion_fade=0.1)
    assert isinstance(s.emotion, presets.Preset) and s.emotion == presets.load("happy")
    assert s.emotion_name == "happy" and s.emotion_label == "happy"
    assert s.fps == pytest.approx(30000 / 1001) and s.fps_text == "29.97"
    assert (s.viseme_set, s.coarticulation, s.language, s.emotion_fade) == ("arkit", "rules", "de", 0.1)
    assert s.visemes.name == "arkit" and s.visemes is s.visemes      # read once
    default = LineSettings.of()
    assert default.emotion == presets.load("neutral") and (default.fps, default.fps_text) == (30.0, "30")
    assert default.align == AlignSettings() and default.language is None


def test_a_preset_given_whole_or_as_a_document_keeps_no_name_of_its_own(tmp_path):
    angry = presets.load("angry")
    assert LineSettings.of(angry).emotion is angry and LineSettings.of(angry).emotion_name == ""
    doc = LineSettings.of({"base": "sad", "gain": 0.5})
    assert doc.emotion.gain == 0.5 and doc.emotion_label == "sad"
    nameless = tmp_path / "nameless.json"
    nameless.write_text(json.dumps({"name": "", "base": "sad"}))
    assert LineSettings.of(nameless).emotion_label == str(nameless)       # the file names it
    assert LineSettings.of(presets.load(nameless)).emotion_label == "preset"


@pytest.mark.parametrize("options, option, message", [
    ({"coarticulation": "smooth"}, "coarticulation", "unknown coarticulation model 'smooth': use dominance or rules"),
    ({"emotion_fade": -1.0}, "emotion_fade", "the emotion fade must be 0 s or more, got -1.0"),
    ({"emotion_fade": float("nan")}, "emotion_fade", "the emotion fade must be 0 s or more, got nan"),
    ({"emotion_fade": float("inf")}, "emotion_fade", "the emotion fade must be 0 s or more, got inf"),
    ({"fps": "fast"}, "fps", "frame rate 'fast' is not a number"),
    ({"fps": 0}, "fps", "frame rate 0 is out of range (1-1000 fps)"),
    ({"language": "xx"}, "language", "unknown language 'xx'"),
])
def test_each_bad_value_is_refused_when_built_naming_its_option(options, option, message):
    with pytest.raises(SettingError) as err:
        LineSettings.of(**options)
    assert err.value.option == option and str(err.value).startswith(message)
    with pytest.raises(SettingError):                  # and when changed
        LineSettings.of().replace(**options)


def test_a_preset_that_cannot_be_read_says_why():
    with pytest.raises(PresetError, match="grumpy"):
        LineSettings.of("grumpy")
    with pytest.raises(TypeError, match="LineSettings.of"):
        LineSettings(emotion="happy")


def test_replace_keeps_what_it_does_not_change_and_renames_what_it_does():
    s = LineSettings.of("angry", fps="24000/1001", language="pt-BR")
    t = s.replace(emotion="sad", viseme_set="oculus")
    assert (t.emotion_name, t.emotion) == ("sad", presets.load("sad"))
    assert (t.fps, t.fps_text, t.language, t.viseme_set) == (s.fps, "24000/1001", "pt-BR", "oculus")
    assert t.visemes.name == "oculus" and s.visemes.name == "default"
    u = t.replace(fps=25)
    assert (u.fps, u.fps_text, u.emotion_name) == (25.0, "25", "sad")
    with pytest.raises(dataclasses.FrozenInstanceError):
        u.fps = 30


def test_the_learned_presets_own_viseme_set():
    p = presets.read("neutral")
    p["learned"] = {"viseme_set": "arkit", "targets": {"aa": {"jawOpen": 1.0}}}
    s = LineSettings.of(p)
    assert s.visemes.name == "arkit" and s.visemes.mix("aa") == {"jawOpen": 1.0}
    with pytest.raises(LipSyncError, match="learned with the 'arkit' viseme set; it cannot drive 'oculus'"):
        _ = s.replace(viseme_set="oculus").visemes


@pytest.mark.parametrize("emotion", presets.builtin_names() + ["learned"])
def test_settings_go_to_a_worker_as_plain_data_and_come_back_the_same(emotion):
    if emotion == "learned":
        doc = presets.read("happy")
        doc["learned"] = {"viseme_set": "arkit", "targets": {"aa": {"jawOpen": 0.9}}, "report": "x.report.json"}
        emotion = doc
    s = LineSettings.of(emotion, fps="24000/1001", language="de", dictionary="/d.dict", emotion_fade=0.2,
                        align=AlignSettings(workers=3, piece=5.0))
    doc = json.loads(json.dumps(s.to_dict()))
    back = LineSettings.from_dict(doc)
    assert back == s and back.emotion.key() == s.emotion.key() and back.fps_text == "24000/1001"


def test_a_batch_line_overrides_the_runs_settings_with_its_own_columns():
    defaults = LineSettings.of("happy", fps="25", coarticulation="rules", language="de")
    line = batch.Line(2, audio="a.wav", emotion="sad", fps="29.97")
    own = batch.line_settings(line, defaults)
    assert (own.emotion_name, own.fps_text, own.viseme_set, own.language) == ("sad", "29.97", None, "de")
    assert own.coarticulation == "rules" and own.align.workers == 1      # lines run in parallel, one core each
    same = batch.line_settings(batch.Line(3, audio="b.wav", viseme_set="", language=""), defaults)
    assert (same.emotion, same.fps, same.language) == (defaults.emotion, 25.0, "de")


@pytest.mark.parametrize("command", ["analyze", "batch"])
@pytest.mark.parametrize("flag, value, says", [
    ("--fps", "fast", "error: --fps: frame rate 'fast' is not a number"),
    ("--emotion-fade", "-1", "error: --emotion-fade: the emotion fade must be 0 s or more"),
    ("--language", "xx", "error: --language: unknown language 'xx'"),
    ("--emotion", "grumpy", "error: grumpy: field 'name' is not a preset"),
])
def test_the_command_line_names_the_option_of_a_bad_setting(command, flag, value, says, tmp_path, capsys,
                                                             fixtures):
    (tmp_path / "m.csv").write_text("audio,text\n" + str(fixtures / "bob_map.wav") + ",Bob\n")
    args = (["analyze", str(fixtures / "bob_map.wav"), "--text", "Bob", "--json", str(tmp_path / "o.json")]
            if command == "analyze" else ["batch", str(tmp_path / "m.csv"), "--out", str(tmp_path / "out")])
    assert cli.main(args + [flag, value]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith(says) and len(err.splitlines()) == 1, err
    assert not (tmp_path / "o.json").exists() and not (tmp_path / "out").exists()
