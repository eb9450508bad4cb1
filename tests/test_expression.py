"""The expression layer: each preset's action units over a line, alive
(eased, following the voice, brows on accents, cross-fading), bounded where
speech drives the same key, and the lips still closing on /p b m/."""

import csv
import json
import sys

import numpy as np
import pytest

from addon.engine import conventions, expression, learning, mapping, pipeline, presets, visemes
from addon.engine.errors import PresetError
from addon.engine.language import phone_class
from addon.engine.settings import LineSettings
from voice_synth import voice

sys.path.insert(0, str(presets.DATA.parents[3] / "sample_rigs"))
from human import ARKIT_52

EMFACS = {"happy": {"AU6", "AU12"}, "sad": {"AU1", "AU4", "AU15"}, "angry": {"AU4", "AU5", "AU7", "AU23"},
          "surprised": {"AU1", "AU2", "AU5", "AU26"}, "afraid": {"AU1", "AU2", "AU4", "AU5", "AU20"},
          "disgusted": {"AU9", "AU10", "AU15"}}
FPS = 30


@pytest.fixture(scope="module")
def line():
    return voice(0.5, syllables=("AA", "IY", "UW", "EH", "AA", "IY", "UW", "EH"))


@pytest.fixture(scope="module")
def results(line):
    snd, al = line
    return {name: pipeline.analyze(snd, settings=LineSettings.of(emotion=name, fps=FPS), alignment=al)
            for name in presets.builtin_names()}


def _speaking(r, al):
    return (r.times >= al.phones[0].start) & (r.times <= al.phones[-1].end)


def test_each_preset_drives_its_emfacs_units_and_neutral_none(line, results):
    snd, al = line
    assert presets.load("neutral").expression == {}
    assert results["neutral"].expression == {}
    for name, units in EMFACS.items():
        assert set(presets.load(name).expression) == units
        r = results[name]
        speaking = _speaking(r, al)
        assert units <= set(r.expression), name
        for u in units:
            assert r.expression[u][speaking].mean() >= 0.2, (name, u)
        for v in r.expression.values():
            assert v.shape == r.times.shape and v.min() >= 0.0 and v.max() <= 1.0
        # The articulation is computed as before: the expression is a layer beside it.
        assert r.curves.shape == results["neutral"].curves.shape


def test_json_and_csv_carry_the_units(tmp_path, results):
    r = results["angry"]
    doc = json.loads(json.dumps(r.to_dict()))
    assert set(doc["expression"]) == set(r.expression)
    assert len(doc["expression"]["AU4"]) == len(doc["frames"]["time"])
    assert np.allclose(doc["expression"]["AU4"], r.expression["AU4"], atol=1e-4)
    assert results["neutral"].to_dict()["expression"] == {}
    r.write_csv(tmp_path / "a.csv")
    rows = list(csv.reader(open(tmp_path / "a.csv")))
    after = 2 + len(r.viseme_set.visemes)   # frame, time, the visemes, then the units, then the gestures
    assert rows[0][after:after + len(r.expression)] == list(r.expression)
    assert float(rows[10][rows[0].index("AU7")]) == pytest.approx(r.expression["AU7"][9], abs=1e-4)
    results["neutral"].write_csv(tmp_path / "n.csv")
    head = next(csv.reader(open(tmp_path / "n.csv")))
    assert head[after - 1] == results["neutral"].viseme_set.visemes[-1] and not head[after].startswith("AU")


def test_preset_field_is_checked_and_a_zero_takes_a_unit_out():
    with pytest.raises(PresetError, match=r"'expression\.AU99' is not an action unit"):
        presets.as_preset({"name": "x", "expression": {"AU99": 0.5}})
    with pytest.raises(PresetError, match=r"'expression\.AU12' must be a number between 0 and 1"):
        presets.as_preset({"name": "x", "expression": {"AU12": 1.5}})
    with pytest.raises(PresetError, match="'expression' must map"):
        presets.as_preset({"name": "x", "expression": ["AU12"]})
    smirk = presets.as_preset({"name": "smirk", "base": "happy", "expression": {"AU6": 0, "AU12": 0.3}})
    assert smirk.expression == {"AU12": 0.3}
    assert presets.Preset.from_dict(smirk.to_dict()) == smirk
    flat = presets.to_flat(smirk)
    assert flat["expression.AU12"] == 0.3 and presets.from_flat(flat) == smirk.to_dict()
    none = presets.as_preset({"name": "flat", "base": "happy", "expression": {"AU6": 0, "AU12": 0}})
    assert none.expression == {} and "expression" not in none.to_dict()


def test_eases_in_and_out_at_the_line_ends_and_never_jitters(line, results):
    snd, al = line
    first, last = al.phones[0].start, al.phones[-1].end
    for name in EMFACS:
        r = results[name]
        for u, v in r.expression.items():
            # Still until the lead-in (0.15 s before the first phoneme), the smoothing's edge aside.
            assert v[0] == 0.0 and v[r.times < first - 0.16].max() < 0.02, (name, u)
            assert v[-1] == 0.0 and v[r.times > last + 0.16].max() < 0.02, (name, u)
            if not expression.lower_face(u):
                # The upper face moves at most 0.1 a frame at 30 fps: easing, not popping.
                assert np.abs(np.diff(v)).max() <= 0.1, (name, u)


def test_intensity_follows_the_voice_and_brows_rise_on_accents():
    phones = [("M", 0.3, 0.35), ("AA", 0.35, 0.6), ("S", 0.6, 0.65), ("M", 0.8, 0.85), ("AA", 0.85, 1.1),
              ("S", 1.1, 1.15), ("M", 1.3, 1.35), ("AA", 1.35, 1.6), ("S", 1.6, 1.65)]
    times = np.arange(0, 2.0, 1 / FPS)
    flat = np.array([np.nan, 120, np.nan, np.nan, 120, np.nan, np.nan, 120, np.nan])
    accent = flat.copy()
    accent[4] = 120 * 2 ** (4 / 12)      # the middle vowel 4 semitones up
    happy = {"AU6": 0.5, "AU12": 0.6}
    calm = expression.unit_curves(happy, times, phones, flat, FPS, np.full(len(times), -1.0))
    excited = expression.unit_curves(happy, times, phones, flat, FPS, np.full(len(times), 1.0))
    mid = (times > 0.6) & (times < 1.3)
    assert (excited["AU12"][mid] > calm["AU12"][mid] + 0.2).all()
    assert "AU1" not in calm                         # no accent: the brows stay where the preset puts them
    raised = expression.unit_curves(happy, times, phones, accent, FPS)
    peak = np.argmin(np.abs(times - 0.975))
    assert raised["AU1"][peak] > 0.08 and raised["AU2"][peak] > 0.08
    assert raised["AU1"][times < 0.6].max() < 0.02 and raised["AU1"][times > 1.4].max() < 0.02
    assert expression.unit_curves({}, times, phones, accent, FPS) == {}   # neutral keeps still


def test_cross_fades_with_emotion_changes(line, results):
    snd, al = line
    change = al.words[4].start
    mixed = pipeline.analyze(snd, settings=LineSettings.of(emotion="neutral", fps=FPS), alignment=al,
                             emotion_changes=[(change, "happy")])
    t = mixed.times
    assert set(mixed.expression) == set(results["happy"].expression)
    for u, v in mixed.expression.items():
        assert (v[t < change - 0.3] == 0).all()
        assert np.allclose(v[t >= change], results["happy"].expression[u][t >= change])
        assert np.abs(np.diff(v)).max() <= 1.0 / (0.3 * FPS) + 0.1


def _arkit_keys(r, units_scale=1.0):
    """The ARKit rig's shape-key curves for a result: speech through the
    ARKit viseme set and the expression through the ARKit convention,
    combined, with the rig's closure rule applied."""
    conv = conventions.load("arkit")
    vset = visemes.load("arkit")
    idx = conventions.NameIndex(["Basis"] + list(ARKIT_52))
    m = conventions.match(conv, vset, idx)
    face = conventions.expression_match(["Basis"] + list(ARKIT_52), [conv])
    names, values = mapping.shape_key_curves(r.curves, list(vset.visemes), m.mapping)
    ex_names, ex_values = expression.key_curves(r.expression, face.mapping, len(values))
    names, values = expression.combine(names, values, ex_names, ex_values * units_scale)
    closing = {**m.mapping, **{f"expression {u}": mix for u, mix in face.mapping.items() if expression.lower_face(u)}}
    return conventions.apply_closure(names, values, r.closure, m.closure, closing)


def test_speech_and_expression_on_one_key_are_bounded_and_defined():
    speech = np.array([[0.0, 0.5, 1.0, 0.3]]).T.repeat(2, axis=1)
    ex = np.array([[0.6, 0.6, 0.6, 0.0]]).T
    names, out = expression.combine(["mouthSmileLeft", "jawOpen"], speech, ["mouthSmileLeft", "browInnerUp"],
                                    np.hstack([ex, ex]))
    assert names == ["mouthSmileLeft", "jawOpen", "browInnerUp"]
    smile = out[:, 0]
    assert np.allclose(smile, [0.6, 0.8, 1.0, 0.3])          # 1 - (1 - s)(1 - e)
    assert (smile >= np.maximum(speech[:, 0], ex[:, 0]) - 1e-12).all() and smile.max() <= 1.0
    assert np.allclose(out[:, 1], speech[:, 1]) and np.allclose(out[:, 2], ex[:, 0])


def test_the_closing_pose_presses_no_further_than_the_expression_holds_the_lips():
    times = np.arange(0, 1.0, 1 / FPS)
    phones = [("AA", 0.0, 0.4), ("M", 0.4, 0.6), ("AA", 0.6, 1.0)]
    names = ["mouthPressLeft", "mouthRollUpper", "mouthClose"]
    speech = np.full((len(times), 3), 0.4)
    hold = expression.dynamics()["seal_hold"]
    m = (times >= 0.4) & (times <= 0.6)
    away = np.abs(times - 0.5) > 0.1 + expression.dynamics()["closure_ramp"] + 1e-9
    for smile, kept in ((hold, 0.0), (hold / 2, 0.5), (0.0, 1.0)):
        ex = np.full((len(times), 1), smile)
        out = expression.seal(names, speech, {"mouthPressLeft", "mouthRollUpper"}, ["mouthSmileLeft"], ex,
                              {"mouthSmileLeft"}, times, phones)
        assert np.allclose(out[m, :2], 0.4 * kept), smile        # on the /m/: as much as the smile leaves
        assert np.allclose(out[away], speech[away]) and np.allclose(out[:, 2], 0.4)   # elsewhere, other keys: as was
    # Upper-face keys hold nothing closed.
    out = expression.seal(names, speech, {"mouthPressLeft"}, ["browInnerUp"], np.ones((len(times), 1)),
                          {"mouthSmileLeft"}, times, phones)
    assert np.array_equal(out, speech)


@pytest.mark.parametrize("name", sorted(EMFACS))
def test_lips_close_at_every_bilabial_under_every_preset_on_arkit(line, name):
    snd, al = line
    r = pipeline.analyze(snd, settings=LineSettings.of(emotion=name, viseme_set="arkit", fps=FPS), alignment=al)
    names, values = _arkit_keys(r)
    col = {k: i for i, k in enumerate(names)}
    for p in al.phones:
        if phone_class(p.phone) != "bilabial":
            continue
        core = (r.times >= p.start + 0.01) & (r.times <= p.end - 0.01)
        if not core.any():
            continue
        v = values[core]
        # ARKit lips meet when mouthClose equals jawOpen, and nothing lifts them apart.
        assert np.allclose(v[:, col["mouthClose"]], v[:, col["jawOpen"]], atol=0.03), (name, p)
        for k in ("mouthUpperUpLeft", "mouthUpperUpRight", "mouthLowerDownLeft", "mouthFunnel"):
            if k in col:
                assert v[:, col[k]].max() < 0.05, (name, p, k)
        whole = (r.times >= p.start) & (r.times <= p.end)
        for u in ("AU10", "AU26"):          # the units that part the lips give way over the whole phoneme
            if u in r.expression:
                assert r.expression[u][whole].max() < 0.05, (name, u)
    if name == "happy":   # the smile holds through the closures: only part of it yields
        smile = values[:, col["mouthSmileLeft"]]
        inside = (r.times > al.phones[0].start + 0.3) & (r.times < al.phones[-1].end - 0.3)
        assert smile[inside].min() > 0.3


def test_expression_keys_by_convention():
    arkit = ["Basis"] + list(ARKIT_52)
    everything = conventions.load_all()
    m = conventions.expression_match(arkit, everything)
    assert m.convention == "arkit" and m.missing == []
    assert m.mapping["AU12"] == {"mouthSmileLeft": 1.0, "mouthSmileRight": 1.0}
    assert m.mapping["AU1"] == {"browInnerUp": 1.0} and m.mapping["AU26"] == {"jawOpen": 1.0}
    # Ready Player Me: Oculus visemes to speak, ARKit blendshapes for the face.
    rpm = ["Basis", "viseme_sil", "viseme_PP", "viseme_aa"] + list(ARKIT_52)
    assert conventions.expression_match(rpm, everything, prefer="oculus").convention == "arkit"
    oculus_only = ["Basis"] + [f"viseme_{v}" for v in visemes.load("oculus").visemes]
    none = conventions.expression_match(oculus_only, everything)
    assert none.mapping == {} and "AU12" in none.missing
    vroid = ["Basis", "Fcl_MTH_A", "Fcl_MTH_I", "Fcl_BRW_Angry", "Fcl_BRW_Sorrow", "Fcl_BRW_Surprised",
             "Fcl_EYE_Surprised", "Fcl_EYE_Fun", "Fcl_EYE_Angry", "Fcl_MTH_Up", "Fcl_MTH_Sorrow"]
    v = conventions.expression_match(vroid, everything)
    assert v.convention == "vroid"
    assert v.mapping["AU4"] == {"Fcl_BRW_Angry": 1.0} and v.mapping["AU15"] == {"Fcl_MTH_Sorrow": 0.7}
    assert {"AU9", "AU10", "AU20"} <= set(v.missing)
    cc = ["Basis", "Brow_Raise_Inner_L", "Brow_Raise_Inner_R", "Mouth_Smile_L", "Mouth_Smile_R", "V_Open"]
    assert conventions.expression_match(cc, everything).mapping["AU12"] == {"Mouth_Smile_L": 1.0,
                                                                              "Mouth_Smile_R": 1.0}


def test_a_bad_expression_section_is_named(tmp_path):
    doc = json.loads(open(conventions.DATA / "vroid.json", encoding="utf-8").read())
    doc["expression"]["AU77"] = ["Fcl_BRW_Fun"]
    with pytest.raises(PresetError, match=r"mine.json: field 'expression\.AU77' is not an action unit"):
        conventions.from_dict(doc, "mine.json")
    doc["expression"] = {"AU1": [{"Fcl_BRW_Sorrow": -1}]}
    with pytest.raises(PresetError, match=r"mine.json.*expression\.AU1"):
        conventions.from_dict(doc, "mine.json")


def _capture(strengths, rest=0.05, seed=0):
    """An ARKit capture of a line whose face shows ``strengths``: the
    expression channels follow the units' curves (without the voice) on a
    resting value, with noise; the mouth's speech channels are noise."""
    snd, al = voice(0.5, syllables=("AA", "IY", "UW", "EH", "AA", "IY"), seed=seed)
    times = np.arange(0, al.duration, 1 / FPS)
    phones = [(p.phone, p.start, p.end) for p in al.phones]
    pitch = np.full(len(phones), np.nan)
    curves = expression.unit_curves(strengths, times, phones, pitch, FPS)
    face = conventions.expression_match(["Basis"] + list(ARKIT_52), conventions.load_all())
    rng = np.random.default_rng(seed)
    y = rest + rng.normal(0, 0.01, (len(times), len(ARKIT_52)))
    for u, v in curves.items():
        for k in face.mapping[u]:
            y[:, ARKIT_52.index(k)] += v
    return times, np.clip(y, 0, 1), phones, pitch, snd, al


def test_the_expression_is_fitted_from_a_capture():
    truth = {"AU1": 0.5, "AU4": 0.3, "AU12": 0.7}
    clips = [_capture(truth, seed=s)[:4] for s in range(3)]
    fitted = expression.fit(clips, list(ARKIT_52), FPS)
    assert set(fitted) == set(expression.units())          # an ARKit capture shows every unit
    for u, f in fitted.items():
        assert f["strength"] == pytest.approx(truth.get(u, 0.0), abs=0.04), u
    assert fitted["AU12"]["channels"] == ["mouthSmileLeft", "mouthSmileRight"]
    # A capture of the mouth alone (Oculus visemes) shows no unit.
    mouth = [f"viseme_{v}" for v in visemes.load("oculus").visemes]
    assert expression.fit([(t, np.zeros((len(t), len(mouth))), ph, pi) for t, _y, ph, pi in clips], mouth, FPS) == {}


def test_a_learned_preset_carries_the_captured_expression():
    truth = {"AU6": 0.4, "AU12": 0.6}
    clips = []
    for seed in range(2):
        times, y, _ph, _pi, snd, al = _capture(truth, seed=seed)
        clips.append(learning.TrainingClip(f"c{seed}", snd, al, times, y, list(ARKIT_52)))
    result = learning.learn(clips, emotion="sad", viseme_set="arkit", name="smiley", max_iter=3, keep_learned=True,
                         delay=0.0)
    got = result.preset["expression"]
    assert set(got) == {"AU6", "AU12"}, got       # sad's own brows and frown are not in the capture
    assert got["AU6"] == pytest.approx(0.4, abs=0.05) and got["AU12"] == pytest.approx(0.6, abs=0.05)
    assert result.report["expression"]["AU12"]["channels"] == ["mouthSmileLeft", "mouthSmileRight"]
