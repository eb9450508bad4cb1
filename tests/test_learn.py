"""Learning a preset from example animation.

The examples are synthesized: tracks of 52 ARKit channels made by a known
"character" (dominance parameters and viseme poses unlike any built-in
preset) through the engine's own synthesis path, on the real phoneme
timings of the shipped speech at three speaking rates, plus Gaussian noise
of sigma = 0.01.

Tolerances.  With noise of sigma, a perfect model has an RMSE of sigma
against the noisy tracks.  A fitted model whose own error is e scores
sqrt(sigma^2 + e^2); requiring at most 1.5 sigma allows e up to 1.1 sigma,
about 1 % of the 0-1 range, far below what an animator sees.  Parameters
are checked where the data identify them: classes with many occurrences
(vowels, alveolars) and only the ratios of alphas, since scaling every
alpha alike leaves the blend unchanged.  Bilabial dominance is not checked:
the closure step overrides the blend on /p b m/, so the tracks say little
about it.
"""

import json

import numpy as np
import pytest

from addon.engine import audio as audio_mod
from addon.engine import learning, pipeline, presets, visemes
from addon.engine.learning import capture
from addon.engine.alignment import align_audio
from addon.engine.cli import main as cli_main
from addon.engine.settings import LineSettings
from addon.engine.errors import ImportFormatError, LipSyncError, PresetError

from conftest import FIXTURES, SAMPLE, write_wav
from mismatch import stretch

SIGMA = 0.01
CHANNELS = list(capture.ARKIT)


def _truth():
    rng = np.random.default_rng(1)
    vs = visemes.load("arkit")
    poses = {v: {str(ch): round(float(rng.uniform(0.2, 0.9)), 3) for ch in rng.choice(CHANNELS, 5, replace=False)}
             for v in vs.visemes if v != "sil"}
    p = presets.read("neutral")
    p["name"] = "character B"
    p["dominance"]["classes"]["vowel"].update(theta=8.0, phi=10.0)
    p["dominance"]["classes"]["bilabial"].update(alpha=6.0, theta=60.0, phi=40.0)
    p["dominance"]["classes"]["alveolar"].update(alpha=0.5, theta=35.0, phi=30.0)
    p["learned"] = {"viseme_set": "arkit", "targets": poses}
    return presets.validate(p), poses


@pytest.fixture(scope="module")
def examples():
    """12 clips: 4 recordings x 3 speaking rates, tracks from character B."""
    sources = [(FIXTURES / "bob_map.wav", (FIXTURES / "bob_map.txt").read_text()),
               (FIXTURES / "fast_bilabials.wav", (FIXTURES / "fast_bilabials.txt").read_text()),
               (SAMPLE / "hello.wav", (SAMPLE / "hello.txt").read_text()),
               (FIXTURES / "pause.wav", "First part of the line. And the second part after a long pause.")]
    truth, poses = _truth()
    vs = visemes.load("arkit")
    truth_set = visemes.with_targets(vs, poses)
    rng = np.random.default_rng(7)
    clips, clean = [], []
    for path, text in sources:
        snd = audio_mod.load(path)
        al = align_audio(snd, text)
        for f in (0.85, 1.0, 1.2):
            s2, a2 = (snd, al) if f == 1.0 else stretch(snd, al, f)
            probe = learning.TrainingClip("probe", s2, a2, np.array([0.0, s2.duration]), np.zeros((2, len(CHANNELS))),
                                       CHANNELS)
            prepared = learning.prepare(probe, vs, truth, 60.0, CHANNELS)
            y = learning.synthesise(prepared, truth, truth_set, CHANNELS, 60.0, poses)
            clean.append(y)
            clips.append(learning.TrainingClip(f"{path.stem}@{f}", s2, a2, prepared.times,
                                            y + rng.normal(0, SIGMA, y.shape), CHANNELS))
    return clips, truth


def test_recovers_a_known_model(examples):
    clips, truth = examples
    result = learning.learn(clips, emotion="neutral", viseme_set="arkit", name="b", heldout=[2, 5, 10], max_iter=40)
    r = result.report
    assert r["learned"]["heldout"]["rmse"] <= 1.5 * SIGMA
    assert r["learned"]["heldout"]["variance_explained"] > 0.95
    assert r["pca"]["variance_kept"] >= 0.99
    cl, tc = result.preset["dominance"]["classes"], truth["dominance"]["classes"]
    for cls, par in (("vowel", "theta"), ("vowel", "phi"), ("alveolar", "theta"), ("alveolar", "phi")):
        assert cl[cls][par] == pytest.approx(tc[cls][par], rel=0.15), (cls, par)
    ratio = cl["alveolar"]["alpha"] / cl["vowel"]["alpha"]
    assert ratio == pytest.approx(tc["alveolar"]["alpha"] / tc["vowel"]["alpha"], rel=0.15)
    # Held-out error stopped the fit, or it converged; either way it is reported.
    assert r["fit"]["history"][0]["heldout_cost"] > min(h["heldout_cost"] for h in r["fit"]["history"])
    assert r["better_than_builtin"] and r["builtin"]["heldout"]["rmse"] > 3 * r["learned"]["heldout"]["rmse"]


def test_more_clips_lower_the_heldout_error(examples):
    clips, _truth_preset = examples
    held = [2, 5]                 # bob_map and fast_bilabials at rate 1.2, the same in every run
    pool = [i for i in range(len(clips)) if i not in held]
    errors = []
    for n in (2, 5, 10):
        chosen = pool[:n] + held
        sub = [clips[i] for i in chosen]
        r = learning.learn(sub, emotion="neutral", viseme_set="arkit", heldout=[n, n + 1], max_iter=25).report
        errors.append(r["learned"]["heldout"]["rmse"])
        assert r["learned"]["heldout"]["rmse"] < r["builtin"]["heldout"]["rmse"]
    assert errors[0] > errors[1] > errors[2]


def test_learned_preset_plugs_into_generation(examples, tmp_path):
    clips, _ = examples
    result = learning.learn(clips[:6], emotion="angry", viseme_set="arkit", name="angry_b", heldout=[5], max_iter=10)
    preset_path, report_path = result.save(tmp_path / "angry_b.json")
    report = json.loads(report_path.read_text())
    assert report["clips"]["heldout"] == [clips[5].name] and report["base_preset"] == "angry"
    loaded = presets.read(preset_path)
    assert loaded["learned"]["report"] == "angry_b.report.json"
    r = pipeline.analyze(SAMPLE / "hello.wav", (SAMPLE / "hello.txt").read_text(),
                         LineSettings.of(emotion=str(preset_path)))
    assert r.viseme_set.name == "arkit"
    assert r.viseme_set.mix("aa") == loaded["learned"]["targets"]["aa"]
    assert r.curves.shape[1] == 15 and 0 <= r.curves.min() and r.curves.max() <= 1
    with pytest.raises(LipSyncError, match="learned with the 'arkit' viseme set"):
        pipeline.analyze(SAMPLE / "hello.wav", "hello", LineSettings.of(emotion=str(preset_path), viseme_set="default"))
    out = tmp_path / "o.json"
    assert cli_main(["analyze", str(SAMPLE / "hello.wav"), "--transcript", str(SAMPLE / "hello.txt"),
                     "--emotion", str(preset_path), "--json", str(out), "--quiet"]) == 0
    assert json.loads(out.read_text())["viseme_set"] == "arkit"


def test_malformed_learned_section_is_named():
    p = presets.read("neutral")
    p["learned"] = {"viseme_set": "arkit", "targets": {"aa": {"jawOpen": "wide"}}}
    with pytest.raises(PresetError, match="learned.targets.aa.jawOpen"):
        presets.validate(p)
    p["learned"] = {"targets": {"aa": {"jawOpen": 0.5}}}
    with pytest.raises(PresetError, match="learned.viseme_set"):
        presets.validate(p)


def test_tracks_that_do_not_match_the_audio(examples):
    clips, _ = examples
    c = clips[0]
    with pytest.raises(LipSyncError, match="tracks cover"):
        learning.TrainingClip("short", c.audio, c.alignment, c.times[:10], c.tracks[:10], CHANNELS)
    with pytest.raises(LipSyncError, match="at least two clips"):
        learning.learn(clips[:1])


# --- capture CSV ---------------------------------------------------------------------

HEADER = "Timecode,BlendShapeCount,EyeBlinkLeft,JawOpen,MouthClose,HeadYaw\n"


def test_live_link_face_csv(tmp_path):
    f = tmp_path / "take.csv"
    f.write_text(HEADER + "10:20:30:00.000,61,0.1,0.2,0.0,0.01\n10:20:30:01.500,61,0.1,0.4,0.1,0.02\n"
                 "10:20:30:03.000,61,0.0,0.6,0.0,0.0\n")
    times, values, names = capture.read_capture_csv(f, fps=60)
    assert names == ["eyeBlinkLeft", "jawOpen", "mouthClose"]   # HeadYaw and the count are ignored
    assert times == pytest.approx([0.0, 1.5 / 60, 3 / 60])
    assert values[:, 1] == pytest.approx([0.2, 0.4, 0.6])


def test_seconds_column(tmp_path):
    f = tmp_path / "take.csv"
    f.write_text("time,jaw_open,extra\n0.0,0.1,x\n0.5,0.2,y\n1.0,0.3,z\n")
    times, values, names = capture.read_capture_csv(f)
    assert names == ["jawOpen"] and times[-1] == 1.0


@pytest.mark.parametrize("body, message", [
    ("BlendShapeCount,JawOpen\n61,0.1\n61,0.2\n", "no time column"),
    ("Timecode,JawOpen\n00:00:00:00,0.1\n00:00:00:01\n", "line 3: 1 values, but the header has 2"),
    ("Timecode,JawOpen\n00:00:00:00,0.1\n00:00:00:01,open\n", "line 3: jawOpen = 'open' is not a number"),
    ("Timecode,HeadYaw\n00:00:00:00,0.1\n00:00:00:01,0.2\n", "no ARKit blendshape columns"),
    ("Timecode,JawOpen\n00:00:00:02,0.1\n00:00:00:01,0.2\n", "time does not increase"),
    ("Timecode,JawOpen\n0:0,0.1\n00:00:00:01,0.2\n", "is not HH:MM:SS:FF"),
    ("Timecode,JawOpen\n", "at least two frames"),
])
def test_malformed_capture_csv(tmp_path, body, message):
    f = tmp_path / "bad.csv"
    f.write_text(body)
    with pytest.raises(ImportFormatError, match=message):
        capture.read_capture_csv(f)


def test_learn_command_line(examples, tmp_path, capsys):
    """Files on disk: audio, capture CSV and transcript side by side."""
    clips, _ = examples

    for c in clips[:3]:
        stem = tmp_path / c.name.replace("@", "_")
        write_wav(stem.with_suffix(".wav"), c.audio.samples, c.audio.rate)
        rows = ["time," + ",".join(CHANNELS)] + [f"{t:.5f}," + ",".join(f"{v:.4f}" for v in row)
                                                  for t, row in zip(c.times, c.tracks)]
        stem.with_suffix(".csv").write_text("\n".join(rows) + "\n")
        stem.with_suffix(".txt").write_text(" ".join(w.text for w in c.alignment.words))
    wavs = sorted(str(p) for p in tmp_path.glob("*.wav"))
    out = tmp_path / "mine.json"
    assert cli_main(["learn", *wavs, "--out", str(out), "--emotion", "sad"]) == 0
    said = capsys.readouterr().out
    assert "held out" in said and "wrote" in said
    assert presets.load(out).name == "mine"
    assert (tmp_path / "mine.report.json").is_file()
    assert cli_main(["learn", wavs[0], "--out", str(out)]) == 1
    assert "at least two clips" in capsys.readouterr().err


def test_fit_model_is_the_engines_synthesis(examples):
    """The blend the fit adjusts, with the engine's rest in pauses, closure
    step and closure caps on vowels, gives the curves the engine makes."""
    from addon.engine.learning.model import Model, params_matrix, viseme_curves

    clips, truth = examples
    vs = visemes.load("arkit")
    for clip in (clips[4], clips[10]):   # fast bilabials; the line with a long pause
        prepared = learning.prepare(clip, vs, truth, 60.0, CHANNELS)
        model = Model([prepared], 60.0, truth["smoothing"], [], truth["closure"]["strength"])
        (blend,), _ = model.blend(params_matrix(truth), want_jac=False)
        engine = viseme_curves(prepared, truth, vs, 60.0)
        assert np.abs(np.clip(blend * truth["gain"], 0, 1) - engine).max() < 1e-6
