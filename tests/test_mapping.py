"""Viseme -> shape-key mapping by name, mixing, and key reduction."""

import numpy as np
import pytest

from addon.engine import key_reduction, mapping, visemes

OCULUS_NAMES = ["Basis"] + [f"viseme_{v}" for v in "sil PP FF TH DD kk CH SS nn RR aa E ih oh ou".split()]
ARKIT_NAMES = ["Basis", "jawOpen", "mouthClose", "mouthFunnel", "mouthPucker", "mouthStretchLeft",
               "mouthStretchRight", "mouthSmileLeft", "mouthSmileRight", "mouthRollLower", "eyeBlinkLeft"]


def test_a_sets_own_names_map_with_its_prefixes():
    vs = visemes.load("oculus")
    mp = mapping.auto_map(vs, OCULUS_NAMES)
    assert mp["aa"] == {"viseme_aa": 1.0} and len(mp) == 15


def test_default_set_aliases_ignore_case_and_separators():
    vs = visemes.load("default")
    mp = mapping.auto_map(vs, ["Basis", "m_b_p", "F-V", "Ahh", "oo"])
    assert mp == {"MBP": {"m_b_p": 1.0}, "FV": {"F-V": 1.0}, "AHH": {"Ahh": 1.0}, "UUU": {"oo": 1.0}}
    assert "TH" in mapping.unmapped(vs, mp)


def test_every_name_given_may_be_driven_whatever_its_place():
    """Capture tracks have no basis: the first is mapped like the others
    (a mesh's basis is left out by whoever holds its key blocks)."""
    assert mapping.auto_map(visemes.load("default"), ["MBP"]) == {"MBP": {"MBP": 1.0}}
    vs = visemes.load("arkit")
    tracks = ["jawOpen", "mouthClose", "mouthFunnel", "mouthPucker"]
    mp = mapping.auto_map(vs, tracks)
    assert mp["aa"] == {"jawOpen": 0.7} and mp["PP"] == {"mouthClose": 1.0}
    assert mapping.auto_map(vs, tracks[::-1]) == mp


def test_arkit_mix_keeps_the_blendshapes_the_mesh_has():
    vs = visemes.load("arkit")
    mp = mapping.auto_map(vs, ARKIT_NAMES)
    assert mp["PP"] == {"mouthClose": 1.0, "mouthRollLower": 0.1}  # mouthPress*, mouthRollUpper: not on this mesh
    assert mp["ou"] == {"jawOpen": 0.15, "mouthPucker": 0.9, "mouthFunnel": 0.3}
    assert "eyeBlinkLeft" not in {k for mix in mp.values() for k in mix}
    assert mp["FF"] == {"mouthRollLower": 0.7, "jawOpen": 0.05}
    assert "sil" not in mp  # the rest pose drives nothing, and is not reported missing
    assert mapping.unmapped(vs, mp) == []
    assert mapping.unmapped(vs, mapping.auto_map(vs, ["Basis", "jawOpen"])) == ["PP"]


def test_shape_key_curves_sum_weighted_visemes_and_clip():
    curves = np.array([[0.0, 0.0], [1.0, 0.0], [0.8, 0.9]])
    names, out = mapping.shape_key_curves(curves, ["aa", "oh"], {"aa": {"jawOpen": 0.7}, "oh": {"jawOpen": 0.5,
                                                                                              "funnel": 1.0}})
    assert names == ["jawOpen", "funnel"]
    assert out[:, 0] == pytest.approx([0.0, 0.7, 1.0])  # 0.56 + 0.45 clipped to 1
    assert out[:, 1] == pytest.approx([0.0, 0.0, 0.9])


def test_reduce_keeps_peaks_and_stays_within_tolerance():
    t = np.linspace(0, 4 * np.pi, 400)
    y = np.clip(np.sin(t) * np.exp(-t / 10), 0, None)
    idx = key_reduction.reduce(y, 0.01)
    assert idx[0] == 0 and idx[-1] == len(y) - 1
    assert len(idx) < 60
    interp = np.interp(np.arange(len(y)), idx, y[idx])
    assert np.abs(interp - y).max() <= 0.01 + 1e-12
    assert np.argmax(y) in idx
    assert np.array_equal(key_reduction.reduce(y, 0.0), np.arange(len(y)))
