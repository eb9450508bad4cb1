"""Arousal from the voice, and weights that follow it across lines."""

import json

import numpy as np
import pytest

from addon.engine import arousal, cli, presets
from addon.engine.errors import LipSyncError
from addon.engine.pipeline import analyze
from addon.engine.settings import LineSettings
from conftest import write_wav
from voice_synth import voice


@pytest.fixture(scope="module")
def lines():
    return {"loud": voice(1.0), "quiet": voice(0.0)}


def write_clip(path, snd):
    write_wav(path, snd.samples, snd.rate)


def test_estimate_in_range_with_a_track_and_ranks_effort(lines):
    loud = arousal.estimate(lines["loud"][0])
    quiet = arousal.estimate(lines["quiet"][0])
    for est, snd in ((loud, lines["loud"][0]), (quiet, lines["quiet"][0])):
        assert -1 <= est.value <= 1
        assert len(est.times) == len(est.track) > 10
        assert est.times[-1] == pytest.approx(snd.duration, abs=0.1)
        assert np.isfinite(est.track).all() and (np.abs(est.track) <= 1).all()
        assert np.abs(np.diff(est.track)).max() < 0.2   # smooth
    assert loud.value > quiet.value + 0.3
    assert loud.at([1.0])[0] > quiet.at([1.0])[0]


def test_estimate_does_not_depend_on_the_recording_level(lines):
    snd = lines["loud"][0]
    quieter = type(snd)(snd.samples * 0.1, snd.rate)
    assert arousal.estimate(quieter).value == pytest.approx(arousal.estimate(snd).value, abs=0.01)


def test_model_file_checked(tmp_path):
    bad = tmp_path / "m.json"
    bad.write_text(json.dumps({"bias": 0, "features": {"loudness": {"center": 0, "scale": 1, "weight": 1}}}))
    with pytest.raises(Exception, match="unknown feature 'loudness'"):
        arousal.load_model(bad)
    # Saved with a byte-order mark (Windows Notepad): read as the plain file.
    good = tmp_path / "bom.json"
    good.write_text(json.dumps(arousal.load_model()), encoding="utf-8-sig")
    assert arousal.load_model(good) == arousal.load_model()
    broken = tmp_path / "broken.json"
    broken.write_text('{"bias": 0,\n "features": {\n}', encoding="utf-8")
    with pytest.raises(LipSyncError, match=r"broken\.json.*line 3, column 2"):
        arousal.load_model(broken)
    with pytest.raises(LipSyncError, match=r"missing\.json.*does not exist"):
        arousal.load_model(tmp_path / "missing.json")
    with pytest.raises(LipSyncError, match=r"is a folder, not a file"):
        arousal.load_model(tmp_path)
    model = arousal.load_model()
    assert set(model["features"]) <= set(arousal.FEATURES) and model["features"]


def test_model_named_by_the_environment_says_so(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("LIPSYNC_AROUSAL_MODEL", "nope.json")
    with pytest.raises(LipSyncError) as err:
        arousal.load_model()
    assert str(err.value) == "the arousal model file nope.json named by LIPSYNC_AROUSAL_MODEL does not exist"
    assert cli.main(["arousal", str(tmp_path / "any.wav")]) == 1
    assert "named by LIPSYNC_AROUSAL_MODEL does not exist" in capsys.readouterr().err
    model = tmp_path / "mine.json"
    model.write_text(json.dumps(arousal.load_model(arousal.DATA)), encoding="utf-8")
    monkeypatch.setenv("LIPSYNC_AROUSAL_MODEL", str(model))
    assert arousal.load_model() == arousal.load_model(arousal.DATA)
    monkeypatch.setenv("LIPSYNC_AROUSAL_MODEL", "")
    assert arousal.load_model() == arousal.load_model(arousal.DATA)


def test_arousal_command(tmp_path, capsys, lines):
    a, b = tmp_path / "loud.wav", tmp_path / "quiet.wav"
    write_clip(a, lines["loud"][0])
    write_clip(b, lines["quiet"][0])
    bad = tmp_path / "notes.wav"
    bad.write_text("not audio")
    silent = tmp_path / "silent.wav"
    write_clip(silent, type(lines["loud"][0])(np.zeros(16000, np.float32), 16000))
    rc = cli.main(["arousal", str(a), str(bad), str(silent), str(b)])
    out, err = capsys.readouterr()
    assert rc == 1
    rows = [line.split("\t") for line in out.splitlines()]
    assert [r[0] for r in rows] == [str(a), str(b)]
    assert all(len(r[1].split(".")[1]) == 3 for r in rows)
    assert float(rows[0][1]) > float(rows[1][1])
    errs = err.strip().splitlines()
    assert len(errs) == 2 and str(bad) in errs[0] and "no speech" in errs[1] and "Traceback" not in err
    assert cli.main(["arousal", "--json", str(a)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["path"] == str(a) and -1 <= doc["value"] <= 1
    assert len(doc["track"]["time"]) == len(doc["track"]["value"]) > 5


def follow(amount):
    p = presets.read("neutral")
    p["weights"]["follow_voice"] = amount
    return p


def vowel_weights(result):
    return np.array([w for p, w in zip(result.alignment.phones, result.weights) if p.phone not in ("M", "S")])


def test_follow_voice_zero_is_todays_weights(lines, monkeypatch):
    for snd, al in lines.values():
        zero = analyze(snd, settings=LineSettings.of(emotion=follow(0.0)), alignment=al)
        with monkeypatch.context() as m:   # equations 1-2 alone, no arousal estimated at all
            m.setattr(arousal, "estimate", lambda *a, **k: None)
            today = analyze(snd, settings=LineSettings.of(emotion=follow(0.0)), alignment=al)
        assert np.array_equal(today.weights, zero.weights)
        assert np.array_equal(today.curves, zero.curves)


def test_follow_voice_opens_a_loud_line_wider_than_a_quiet_one(lines):
    r = {(name, amount): analyze(snd, settings=LineSettings.of(emotion=follow(amount)), alignment=al)
         for name, (snd, al) in lines.items() for amount in (0.0, 1.0)}
    # Equations 1-2 alone weigh each line against itself: the two lines get similar weights.
    assert vowel_weights(r["loud", 0.0]).mean() == pytest.approx(vowel_weights(r["quiet", 0.0]).mean(), abs=0.1)
    assert (vowel_weights(r["loud", 1.0]) > vowel_weights(r["loud", 0.0])).all()
    assert (vowel_weights(r["quiet", 1.0]) <= vowel_weights(r["quiet", 0.0])).all()
    assert vowel_weights(r["loud", 1.0]).mean() > vowel_weights(r["quiet", 1.0]).mean() + 0.1
    assert r["loud", 1.0].curves.max() > r["quiet", 1.0].curves.max()


def test_analyze_json_has_the_arousal_and_its_track(lines):
    snd, al = lines["loud"]
    doc = analyze(snd, alignment=al).to_dict()
    assert doc["schema"] == 1 and "phonemes" in doc and "frames" in doc   # existing fields kept
    a = doc["arousal"]
    assert -1 <= a["value"] <= 1 and a["features"]["rate"] > 0
    assert len(a["track"]["time"]) == len(a["track"]["value"]) > 5
    assert doc["emotions"] == [{"emotion": "neutral", "time": 0.0, "fade": None}]


def test_follow_voice_is_a_checked_preset_field():
    p = presets.read("neutral")
    assert p["weights"]["follow_voice"] == 0.5   # the built-in neutral follows the voice half way
    p["weights"]["follow_voice"] = 2
    with pytest.raises(presets.PresetError, match="follow_voice"):
        presets.validate(p)
