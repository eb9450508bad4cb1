"""Naming conventions: real characters' shape-key names, detection, and the
closure rules applied to the shape-key curves."""

import json

import numpy as np
import pytest

from addon.engine import conventions, visemes
from addon.engine.errors import PresetError

SETS = {n: visemes.load(n) for n in visemes.builtin_names()}
CONVENTIONS = conventions.load_all()

ARKIT = ("eyeBlinkLeft eyeLookDownLeft eyeLookInLeft eyeLookOutLeft eyeLookUpLeft eyeSquintLeft eyeWideLeft "
         "eyeBlinkRight eyeLookDownRight eyeLookInRight eyeLookOutRight eyeLookUpRight eyeSquintRight eyeWideRight "
         "jawForward jawLeft jawRight jawOpen mouthClose mouthFunnel mouthPucker mouthLeft mouthRight "
         "mouthSmileLeft mouthSmileRight mouthFrownLeft mouthFrownRight mouthDimpleLeft mouthDimpleRight "
         "mouthStretchLeft mouthStretchRight mouthRollLower mouthRollUpper mouthShrugLower mouthShrugUpper "
         "mouthPressLeft mouthPressRight mouthLowerDownLeft mouthLowerDownRight mouthUpperUpLeft mouthUpperUpRight "
         "browDownLeft browDownRight browInnerUp browOuterUpLeft browOuterUpRight "
         "cheekPuff cheekSquintLeft cheekSquintRight noseSneerLeft noseSneerRight tongueOut").split()
assert len(ARKIT) == 52
CC_ARKIT = ("A01_Brow_Inner_Up A02_Brow_Down_Left A03_Brow_Down_Right A04_Brow_Outer_Up_Left "
            "A05_Brow_Outer_Up_Right A06_Eye_Look_Up_Left A07_Eye_Look_Up_Right A08_Eye_Look_Down_Left "
            "A09_Eye_Look_Down_Right A10_Eye_Look_Out_Left A11_Eye_Look_In_Left A12_Eye_Look_In_Right "
            "A13_Eye_Look_Out_Right A14_Eye_Blink_Left A15_Eye_Blink_Right A16_Eye_Squint_Left A17_Eye_Squint_Right "
            "A18_Eye_Wide_Left A19_Eye_Wide_Right A20_Cheek_Puff A21_Cheek_Squint_Left A22_Cheek_Squint_Right "
            "A23_Nose_Sneer_Left A24_Nose_Sneer_Right A25_Jaw_Open A26_Jaw_Forward A27_Jaw_Left A28_Jaw_Right "
            "A29_Mouth_Funnel A30_Mouth_Pucker A31_Mouth_Left A32_Mouth_Right A33_Mouth_Roll_Upper "
            "A34_Mouth_Roll_Lower A35_Mouth_Shrug_Upper A36_Mouth_Shrug_Lower A37_Mouth_Close A38_Mouth_Smile_Left "
            "A39_Mouth_Smile_Right A40_Mouth_Frown_Left A41_Mouth_Frown_Right A42_Mouth_Dimple_Left "
            "A43_Mouth_Dimple_Right A44_Mouth_Upper_Up_Left A45_Mouth_Upper_Up_Right A46_Mouth_Lower_Down_Left "
            "A47_Mouth_Lower_Down_Right A48_Mouth_Press_Left A49_Mouth_Press_Right A50_Mouth_Stretch_Left "
            "A51_Mouth_Stretch_Right A52_Tongue_Out").split()
RPM = [f"viseme_{v}" for v in "sil PP FF TH DD kk CH SS nn RR aa E I O U".split()]
VRCHAT = [f"vrc.v_{v}" for v in "sil pp ff th dd kk ch ss nn rr aa e ih oh ou".split()]
VROID = ("Fcl_ALL_Neutral Fcl_ALL_Angry Fcl_ALL_Fun Fcl_ALL_Joy Fcl_ALL_Sorrow Fcl_ALL_Surprised Fcl_BRW_Angry "
         "Fcl_BRW_Fun Fcl_EYE_Natural Fcl_EYE_Close Fcl_EYE_Close_R Fcl_EYE_Close_L Fcl_MTH_Close Fcl_MTH_Up "
         "Fcl_MTH_Down Fcl_MTH_Angry Fcl_MTH_Small Fcl_MTH_Large Fcl_MTH_Neutral Fcl_MTH_Fun Fcl_MTH_Joy "
         "Fcl_MTH_Sorrow Fcl_MTH_Surprised Fcl_MTH_SkinFung Fcl_MTH_A Fcl_MTH_I Fcl_MTH_U Fcl_MTH_E Fcl_MTH_O "
         "Fcl_HA_Hide Fcl_HA_Fung1").split()
CC4 = ("V_Open V_Explosive V_Dental_Lip V_Tight_O V_Tight V_Wide V_Affricate V_Lip_Open V_Tongue_up "
       "V_Tongue_Raise V_Tongue_Out V_Tongue_Narrow V_Tongue_Lower V_Tongue_Curl_U V_Tongue_Curl_D").split()
CC3 = ("Open Explosive Dental_Lip Tight-O Tight Wide Affricate Lip_Open Tongue_up Tongue_Raise Tongue_Out "
       "Tongue_Narrow Tongue_Lower Tongue_Curl-U Tongue_Curl-D").split()
ICLONE = "EE Er IH Ah Oh W_OO S_Z Ch_J F_V TH T_L_D_N B_M_P K_G_H_NG AE R None".split()
MPFB = ("sil_00 aa_ah_ax_01 aa_02 ao_03 ey_eh_uh_04 er_05 y_iy_ih_ix_06 w_uw_07 ow_08 aw_09 oy_10 ay_11 h_12 r_13 "
        "l_14 s_z_15 sh_ch_jh_zh_16 th_dh_17 f_v_18 d_t_n_19 k_g_ng_20 p_b_m_21").split()
DAZ = [f"eCTRLv{v}" for v in "AA EE EH ER F IH IY K L M OW S SH T TH UW W".split()]

# (shape keys, mesh name, convention, a viseme and the key it must drive)
RIGS = {
    "ready player me": (RPM, "Wolf3D_Head", "oculus", "ih", "viseme_I"),
    "ready player me with ARKit": (RPM + ARKIT + ["mouthOpen", "mouthSmile"], "Wolf3D_Head", "oculus", "PP",
                                   "viseme_PP"),
    "oculus spelling": ([f"viseme_{v}" for v in "sil PP FF TH DD kk CH SS nn RR aa E ih oh ou".split()], "Head",
                        "oculus", "ou", "viseme_ou"),
    "vrchat": (VRCHAT, "Body", "vrchat", "E", "vrc.v_e"),
    "arkit": (ARKIT, "Face", "arkit", "aa", "jawOpen"),
    "arkit raw strings": ([n.replace("Left", "_L").replace("Right", "_R") for n in ARKIT], "Face", "arkit", "ih",
                          "mouthSmile_L"),
    "live link pascal": ([n[0].upper() + n[1:] for n in ARKIT], "Face", "arkit", "PP", "MouthClose"),
    "fbx channel prefix": ([f"blendShape1.{n}" for n in ARKIT], "Face", "arkit", "aa", "blendShape1.jawOpen"),
    "mesh-name prefix": ([f"Bob_{n}" for n in ARKIT], "Bob", "arkit", "oh", "Bob_mouthFunnel"),
    "character creator numbered arkit": (CC_ARKIT, "CC_Base_Body", "arkit", "PP", "A37_Mouth_Close"),
    "character creator 4": (CC4 + CC_ARKIT, "CC_Base_Body", "character_creator", "oh", "V_Tight_O"),
    "character creator 3": (CC3, "CC_Base_Body", "character_creator", "oh", "Tight-O"),
    "iclone 1:1": (ICLONE, "CC_Base_Body", "iclone", "PP", "B_M_P"),
    "vroid": (VROID, "Face", "vroid", "aa", "Fcl_MTH_A"),
    "old vroid": ([f"Face.M_F00_000_00_{n}" for n in VROID], "Face", "vroid", "ih",
                  "Face.M_F00_000_00_Fcl_MTH_I"),
    "vrm 0.x": (["A", "I", "U", "E", "O", "Blink", "Joy", "Angry"], "Face", "vrm", "ou", "U"),
    "vrm 1.0": (["aa", "ih", "ou", "ee", "oh", "happy", "blink"], "Face", "vrm", "E", "ee"),
    "mmd": (["あ", "い", "う", "え", "お", "まばたき", "ｳｨﾝｸ"], "Face", "vrm", "aa", "あ"),
    "mpfb microsoft": (MPFB + RPM + ARKIT, "Human", "microsoft", "p_b_m_21", "p_b_m_21"),
    "daz genesis 8": (DAZ, "Genesis8Female", "daz_genesis", "MBP", "eCTRLvM"),
    "daz bridge prefix": ([f"Genesis8Female__{n}" for n in DAZ], "Genesis8Female", "daz_genesis", "AHH",
                          "Genesis8Female__eCTRLvAA"),
    "daz genesis 9": ([n.replace("eCTRLv", "facs_ctrl_v") for n in DAZ], "Genesis9", "daz_genesis", "UUU",
                      "facs_ctrl_vUW"),
    "preston blair": (["rest", "MBP", "FV", "L", "etc", "WQ", "AI", "E", "O", "U"], "Toon", "preston_blair", "AI",
                      "AI"),
    "rhubarb": ([f"mouth_{c}" for c in "XABCDEFGH"], "Toon", "rhubarb", "D", "mouth_D"),
    "default": (["MBP", "FV", "TH", "TD", "SZ", "SH", "GK", "L", "R", "AHH", "EH", "IEE", "OHH", "UUU"], "Ada",
                "default", "MBP", "MBP"),
}


@pytest.mark.parametrize("rig", sorted(RIGS))
def test_each_real_rig_is_recognised_and_maps_completely(rig):
    keys, mesh, expected, viseme, key = RIGS[rig]
    found = conventions.detect(["Basis"] + keys, CONVENTIONS, SETS, (mesh,))
    assert found is not None and found.convention.name == expected
    vset = SETS[found.convention.viseme_set]
    assert conventions.unmapped(vset, found.mapping) == []
    assert found.complete
    assert key in found.mapping[viseme]
    driven = {k for mix in found.mapping.values() for k in mix}
    assert driven <= set(keys)  # the mesh's own names, prefixes and all


def test_speech_keys_win_and_every_viseme_key_is_driven():
    found = conventions.detect(["Basis"] + RPM + ARKIT, CONVENTIONS, SETS)
    driven = {k for mix in found.mapping.values() for k in mix}
    assert driven == set(RPM)  # all fifteen, no ARKit blendshape
    # The user's choice of set still picks ARKit.
    forced = conventions.detect(["Basis"] + RPM + ARKIT, CONVENTIONS, SETS, viseme_set="arkit")
    assert forced.convention.name == "arkit"


def test_arkit_closure_rule_is_in_the_mesh_names():
    found = conventions.detect(["Basis"] + CC_ARKIT, CONVENTIONS, SETS)
    assert found.closure.relative == {"A37_Mouth_Close": "A25_Jaw_Open"}
    assert "A29_Mouth_Funnel" in found.closure.relax
    again = conventions.Closure.from_json(json.dumps(found.closure.to_dict()))
    assert again == found.closure
    assert conventions.Closure.from_json("not json") == conventions.Closure()


def test_unrelated_names_match_nothing():
    assert conventions.detect(["Basis", "Smile", "Blink", "Frown"], CONVENTIONS, SETS) is None
    assert conventions.detect(["A"], CONVENTIONS, SETS) is None  # the basis alone


def test_apply_closure_relaxes_other_keys_and_ties_mouth_close_to_the_jaw():
    keys = ["jawOpen", "mouthClose", "mouthFunnel", "mouthPucker"]
    values = np.array([[0.5, 0.0, 0.4, 0.3],     # a vowel
                       [0.2, 1.0, 0.4, 0.3],     # a /b/: closure 1
                       [0.2, 1.0, 0.4, 0.3]])    # half-way out of it
    closure = conventions.Closure("PP", ["mouthFunnel"], {"mouthClose": "jawOpen"})
    names, out = conventions.apply_closure(keys, values, np.array([0.0, 1.0, 0.5]), closure, {})
    assert names == keys
    assert out[0].tolist() == pytest.approx([0.5, 0.0, 0.4, 0.3])
    assert out[1].tolist() == pytest.approx([0.2, 0.2, 0.0, 0.3])   # lips meet on the open jaw; rounding stays
    assert out[2].tolist() == pytest.approx([0.2, 0.2, 0.2, 0.3])


def test_relax_others_spares_the_closure_visemes_keys():
    mapping = {"PP": {"viseme_PP": 1.0}, "aa": {"viseme_aa": 1.0}, "sil": {}}
    closure = conventions.Closure("PP", "others")
    _names, out = conventions.apply_closure(["viseme_PP", "viseme_aa"], np.array([[0.9, 0.3]]), np.array([1.0]),
                                            closure, mapping)
    assert out.tolist() == [[0.9, 0.0]]


def test_a_studio_convention_file_is_loaded_and_replaces_a_builtin(tmp_path, monkeypatch):
    doc = {"name": "studio", "label": "Our rigs", "viseme_set": "oculus",
           "visemes": {"PP": ["lips_shut"], "aa": ["jaw_wide"]}, "closure": {"viseme": "PP", "relax": "others"}}
    (tmp_path / "studio.json").write_text(json.dumps(doc), encoding="utf-8")
    monkeypatch.setenv(conventions.ENV_DIRS, str(tmp_path))
    convs = conventions.load_all()
    found = conventions.detect(["Basis", "lips_shut", "jaw_wide"], convs, SETS)
    assert found.convention.label == "Our rigs" and found.mapping["aa"] == {"jaw_wide": 1.0}


@pytest.mark.parametrize("doc, field", [
    ({"name": "x", "viseme_set": "oculus", "visemes": {"QQ": ["a"]}}, "visemes.QQ"),
    ({"name": "x", "viseme_set": "oculus", "visemes": {"PP": [{"a": "heavy"}]}}, "visemes.PP"),
    ({"name": "x", "viseme_set": "oculus", "visemes": {}, "closure": {"relax": 3}}, "closure.relax"),
    ({"name": "x", "viseme_set": "oculus", "visemes": {}, "closure": {"viseme": "MBP"}}, "closure.viseme"),
    ({"viseme_set": "oculus"}, "name"),
])
def test_malformed_convention_names_the_field(doc, field):
    with pytest.raises(PresetError, match=f"field '{field}'"):
        conventions.from_dict(doc, "studio.json")


STUDIO = {"name": "studio", "label": "Our rigs", "viseme_set": "oculus", "visemes": {"PP": ["lips_shut"]}}


def test_a_convention_file_saved_with_a_byte_order_mark_loads(tmp_path):
    path = tmp_path / "studio.json"
    path.write_bytes(b"\xef\xbb\xbf" + json.dumps(STUDIO).encode("utf-8"))   # Notepad's UTF-8
    assert conventions.load(path).label == "Our rigs"


@pytest.mark.parametrize("content, words", [
    (b'{\n  "name": "studio",\n}\n', ["(file)", "not valid JSON", "line 3, column 1"]),
    (b'["lips_shut"]', ["(top level)", "JSON object"]),
    ('{"label": "Caf\xe9"}'.encode("latin-1"), ["(file)", "not UTF-8", "byte 14"]),
])
def test_a_broken_convention_file_in_the_studio_folder_is_named(tmp_path, monkeypatch, content, words):
    (tmp_path / "studio.json").write_bytes(content)
    monkeypatch.setenv(conventions.ENV_DIRS, str(tmp_path))
    with pytest.raises(PresetError) as err:
        conventions.load_all()
    for w in [str(tmp_path / "studio.json")] + words:
        assert w in str(err.value)
