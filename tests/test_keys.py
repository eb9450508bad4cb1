"""The keying step, without Blender: a line's curves through a mesh's
mapping, the expression beside them, the seal and the give-way on /p b m/,
the user's own keys left alone, and an armature's closing poses."""

from types import SimpleNamespace

import numpy as np
import pytest

from addon.engine import conventions, expression, keys, mapping, pipeline
from addon.engine.settings import LineSettings
from voice_synth import voice

#: Speech on a small rig: lips pressed on /p b m/, a jaw, a spread.
MAPPING = {"MBP": {"close": 1.0, "press": 0.6}, "AHH": {"jaw": 1.0}, "IEE": {"spread": 1.0},
           "EH": {"jaw": 0.5, "smile": 0.3}}
#: The expression's units on the same rig: a smile (lower face), cheeks and brows (upper face).
FACE = {"AU12": {"smile": 1.0}, "AU6": {"cheek": 1.0}, "AU4": {"brow": 1.0}}
#: ARKit's way: the closing pose presses, nothing relaxes.
PRESSING = conventions.Closure(viseme="MBP")
#: VRoid's way: the basis shows closed lips; the other mouth keys relax on /p b m/.
BASIS_CLOSED = conventions.Closure(viseme="MBP", relax="others")


@pytest.fixture(scope="module")
def line():
    """A line of M-vowel-S words (four bilabials), under happy (AU6, AU12) and neutral."""
    snd, al = voice(0.6, syllables=("AA", "IY", "EH", "AA"))
    return {e: pipeline.analyze(snd, settings=LineSettings.of(emotion=e), alignment=al) for e in ("happy", "neutral")}


def _closing(result):
    return expression.closing(result.times, [(p.phone, p.start, p.end) for p in result.alignment.phones])


def _channel(line_keys, name):
    return next(c for c in line_keys.channels if c.name == name)


def test_closing_names_are_the_p_b_m_visemes_keys_in_order_each_once():
    vset = SimpleNamespace(phonemes={"P": ["a"], "B": ["b", "a"], "M": ["c"], "AA": ["d"]})
    mp = {"a": {"x": 1.0, "y": 1.0}, "b": {"y": 1.0, "z": 0.5}, "c": {"x": 1.0, "w": 1.0}, "d": {"open": 1.0}}
    assert keys.closing_names(vset, mp) == ["x", "y", "z", "w"]
    assert keys.closing_names(vset, {"d": {"open": 1.0}}) == []


def test_speech_alone_is_the_mapping_with_the_rigs_closure(line):
    r = line["neutral"]
    got = keys.mesh_keys(r, MAPPING, BASIS_CLOSED, FACE)
    names, values = mapping.shape_key_curves(r.curves, r.viseme_set.visemes, MAPPING)
    names, values = conventions.apply_closure(names, values, r.closure, BASIS_CLOSED, MAPPING)
    assert got.names == names and np.array_equal(got.table(), values)
    assert got.table().shape == (len(r.times), len(names)) and got.frames == len(r.times)
    assert all(c.drivers == (keys.SPEECH,) for c in got.channels)
    # Relaxed on /p b m/: the jaw is shut where the lips close, the closing pose is not.
    shut = r.closure > 0.99
    assert shut.sum() >= 4
    assert np.all(_channel(got, "jaw").values[shut] < 0.01) and _channel(got, "close").values[shut].min() > 0.5
    # Neutral has no expression: nothing but speech, and every key the expression may drive is let go.
    assert got.units == [] and got.expression_keys == [] and got.dropped == ["brow", "cheek"]


def test_on_a_closed_basis_the_mouths_expression_gives_way_on_p_b_m(line):
    r = line["happy"]
    got = keys.mesh_keys(r, {"MBP": {"close": 1.0}, "AHH": {"jaw": 1.0}}, BASIS_CLOSED, FACE)
    assert got.units == ["AU6", "AU12"] and got.no_key == [] and got.dropped == ["brow"]
    smile, cheek = _channel(got, "smile"), _channel(got, "cheek")
    assert smile.drivers == cheek.drivers == (keys.EXPRESSION,)
    assert np.array_equal(cheek.values, np.clip(r.expression["AU6"], 0, 1))     # the upper face stays
    c = _closing(r)
    assert np.allclose(smile.values, r.expression["AU12"] * (1.0 - c))
    assert r.expression["AU12"][c == 1.0].max() > 0.2 and smile.values[c == 1.0].max() == 0.0
    away = c == 0.0
    assert away.any() and np.array_equal(smile.values[away], r.expression["AU12"][away])


def test_a_pressing_closure_is_sealed_by_the_mouths_expression(line):
    happy, neutral = line["happy"], line["neutral"]
    plain = keys.mesh_keys(happy, MAPPING, PRESSING, {})                 # no expression keys on the rig
    sealed = keys.mesh_keys(happy, MAPPING, PRESSING, FACE)
    c = _closing(happy)
    hold = np.clip(happy.expression["AU12"] / expression.dynamics()["seal_hold"], 0.0, 1.0)
    for key in ("close", "press"):          # the closing pose's keys
        press, press0 = _channel(sealed, key).values, _channel(plain, key).values
        assert np.allclose(press, press0 * (1.0 - c * hold))
        assert (press < press0 - 0.05).any() and np.array_equal(press[c == 0.0], press0[c == 0.0])
    # The other visemes' keys are not the seal's.
    for key in ("jaw", "spread"):
        assert np.array_equal(_channel(sealed, key).values, _channel(plain, key).values)
    # No mouth expression (neutral): nothing to seal.
    assert np.array_equal(keys.mesh_keys(neutral, MAPPING, PRESSING, FACE).table(),
                          keys.mesh_keys(neutral, MAPPING, PRESSING, {}).table())


def test_a_key_speech_and_the_expression_share_takes_both(line):
    r = line["happy"]
    got = keys.mesh_keys(r, MAPPING, PRESSING, FACE)
    smile = _channel(got, "smile")
    assert smile.drivers == (keys.SPEECH, keys.EXPRESSION)
    speech = _channel(keys.mesh_keys(r, MAPPING, PRESSING, {}), "smile").values
    assert np.allclose(smile.values, 1.0 - (1.0 - speech) * (1.0 - r.expression["AU12"]))
    # Speech's keys first, then the expression's own.
    assert set(got.names[:-1]) == {k for mix in MAPPING.values() for k in mix} and got.names[-1] == "cheek"
    assert got.driven_only_by(keys.EXPRESSION) == ["cheek"]


def test_the_users_own_keys_on_the_expressions_side_are_left_alone(line):
    r = line["happy"]
    got = keys.mesh_keys(r, MAPPING, PRESSING, FACE, animated={"cheek", "smile", "jaw"})
    assert got.kept == ["cheek"] and "cheek" not in got.names and "cheek" not in got.dropped
    # Speech's keys are speech's, animated or not.
    assert {"smile", "jaw"} <= set(got.names) and _channel(got, "smile").drivers == (keys.SPEECH, keys.EXPRESSION)
    assert got.expression_keys == ["smile"] and got.units == ["AU6", "AU12"]


def test_units_the_rig_has_no_key_for_are_named():
    r = SimpleNamespace(curves=np.zeros((3, 1)), viseme_set=SimpleNamespace(visemes=["AHH"]), times=np.arange(3) / 30,
                        expression={"AU1": np.full(3, 0.5), "AU12": np.full(3, 0.4)}, closure=np.zeros(3),
                        alignment=SimpleNamespace(phones=[]))
    got = keys.mesh_keys(r, {"AHH": {"jaw": 1.0}}, PRESSING, {"AU12": {"smile": 1.0}})
    assert got.no_key == ["AU1"] and got.units == ["AU12"] and np.allclose(_channel(got, "smile").values, 0.4)


def test_an_armature_gets_its_poses_with_the_closure_and_the_closing_poses(line):
    r = line["happy"]
    poses = {"MBP": {"MBP": 1.0}, "AHH": {"AI": 1.0}, "IEE": {"E": 1.0}}
    got = keys.rig_keys(r, poses, BASIS_CLOSED)
    names, values = mapping.shape_key_curves(r.curves, r.viseme_set.visemes, poses)
    names, values = conventions.apply_closure(names, values, r.closure, BASIS_CLOSED, poses)
    assert got.names == names and np.array_equal(got.table(), values)
    assert got.closing == ["MBP"] and np.array_equal(got.closure, r.closure)
    assert got.units == [] and got.kept == []              # the expression drives shape keys only


def test_a_line_with_no_channels_still_spans_its_frames(line):
    r = line["neutral"]
    got = keys.mesh_keys(r, {}, PRESSING)
    assert got.channels == [] and got.table().shape == (len(r.times), 0)
