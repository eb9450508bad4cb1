import json

import pytest

from addon.engine import presets
from addon.engine.errors import PresetError


def test_all_builtin_presets_load():
    assert presets.builtin_names() == ["neutral", "happy", "sad", "angry", "surprised", "afraid", "disgusted"]
    for name in presets.builtin_names():
        p = presets.load(name)
        assert isinstance(p, presets.Preset) and p.name == name
        assert set(p.dominance.classes) >= {"vowel", "bilabial", "silence"}
        assert isinstance(p.dominance.classes["vowel"].theta, float)


def test_a_preset_is_its_json_document_typed():
    """Preset.to_dict gives back the resolved JSON document field for field, and from_dict reads it."""
    for name in presets.builtin_names():
        doc = presets.read(name)
        p = presets.load(name)
        assert p.to_dict() == doc
        assert presets.Preset.from_dict(doc, name) == p
    p = presets.load("happy")
    assert p.weights.range_scale["vowel"] == tuple(presets.read("happy")["weights"]["range_scale"]["vowel"])
    assert p.rules.deletion.phones and p.learned is None
    # A document handed over as a dict may name a base, and is checked.
    assert presets.as_preset({"name": "x", "base": "sad"}).dominance == presets.load("sad").dominance
    with pytest.raises(PresetError, match="gain"):
        presets.as_preset({"name": "x", "gain": "loud"})


def test_angry_and_happy_wider_and_sharper_than_sad():
    sad, angry, happy = (presets.load(n) for n in ("sad", "angry", "happy"))
    for loud in (angry, happy):
        assert loud.weights.range_scale["vowel"][2] > sad.weights.range_scale["vowel"][2]
        assert loud.rules.t_onset < sad.rules.t_onset
        assert loud.dominance.classes["vowel"].theta > sad.dominance.classes["vowel"].theta
        assert loud.smoothing < sad.smoothing


def write(tmp_path, doc):
    f = tmp_path / "p.json"
    f.write_text(json.dumps(doc))
    return f


def test_user_preset_overrides_base(tmp_path):
    f = write(tmp_path, {"name": "mine", "base": "angry", "rules": {"t_onset": 0.2}})
    p = presets.load(f)
    assert p.rules.t_onset == 0.2
    assert p.weights.range_scale["vowel"] == presets.load("angry").weights.range_scale["vowel"]


@pytest.mark.parametrize("doc, field", [
    ({"rules": {"influence": {"VC": "a lot"}}}, "rules.influence.VC"),
    ({"rules": {"t_onset": -1}}, "rules.t_onset"),
    ({"weights": {"range_scale": {"vowel": [1, 2]}}}, "weights.range_scale.vowel"),
    ({"weights": {"other_source": "loudness"}}, "weights.other_source"),
    ({"weights": {"pitch_range": [300, 100]}}, "weights.pitch_range"),
    ({"dominance": {"classes": {"bilabial": {"alpha": 0}}}}, "dominance.classes.bilabial.alpha"),
    ({"rules": {"deletion": {"phones": ["HH", "QQ"]}}}, "rules.deletion.phones"),
    ({"smoothing": 5}, "smoothing"),
    ({"wobble": 1}, "wobble"),
    ({"base": "nonexistent"}, "base"),
])
def test_malformed_preset_names_the_field(tmp_path, doc, field):
    with pytest.raises(PresetError) as err:
        presets.load(write(tmp_path, {"name": "bad", **doc}))
    assert err.value.field == field
    assert field in str(err.value)


def test_invalid_json_and_missing_file(tmp_path):
    f = tmp_path / "broken.json"
    f.write_text("{ not json")
    with pytest.raises(PresetError, match="not valid JSON: line 1"):
        presets.load(f)
    with pytest.raises(PresetError, match="does not exist"):
        presets.load(tmp_path / "missing.json")


def test_flat_round_trip_and_save(tmp_path):
    p = presets.load("happy")
    assert presets.from_flat(presets.to_flat(p)) == p.to_dict()
    presets.save(p, tmp_path / "h.json")
    assert presets.load(tmp_path / "h.json") == p
    p.rules.apex = 7
    with pytest.raises(PresetError, match="rules.apex"):
        presets.save(p, tmp_path / "bad.json")


@pytest.mark.parametrize("doc, field", [
    ({"rules": {"deletion": {"phones": [["HH"]], "threshold": 0.02}}}, "rules.deletion.phones"),
    ({"description": ["not", "text"]}, "description"),
])
def test_a_field_of_the_wrong_kind_is_named_not_a_crash(tmp_path, doc, field):
    with pytest.raises(PresetError) as err:
        presets.load(write(tmp_path, {"name": "bad", **doc}))
    assert err.value.field == field
