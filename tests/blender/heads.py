"""Lip-and-jaw test heads, one per naming convention, and the mouth opening
measured on the mesh Blender evaluates.

Each head is a small mesh: an upper lip, a lower lip meeting it along the
mouth line (the basis shows the mouth closed, as Ready Player Me, ARKit,
VRoid, Character Creator and Daz heads do) and a chin.  Every shape key is a
mix of a few articulatory movements (jaw drop, lips rounded, spread, pressed,
lower lip tucked, ARKit's jaw-relative lip closing ...), so a key does what
its convention says it does: ARKit's ``mouthClose`` alone pushes the lips
through each other and brings them together only on an open jaw; a
``viseme_PP`` presses closed lips; ``Fcl_MTH_A`` opens the jaw.

:func:`mouth_opening` is the lip gap in units of the head's open shape
(``jawOpen``, ``viseme_aa``, ``Fcl_MTH_A``, ``V_Open`` ...): 0 with the lips
together, 1 as open as that shape alone opens it, negative when the lips pass
through each other.
"""

from __future__ import annotations

import bpy
import numpy as np
from human import ARKIT_52  # ARKit's 52 blendshape names (sample_rigs/human.py)

COLUMNS = np.linspace(-1.0, 1.0, 21)
# (role, height): upper lip outer and inner edge, lower lip inner and outer edge, chin.
ROWS = (("upper", 0.12), ("upper", 0.004), ("lower", -0.004), ("lower", -0.12), ("chin", -0.4))


def _layout():
    co, role = [], []
    for r, z in ROWS:
        for x in COLUMNS:
            co.append((x, -0.1 * x * x, z))
            role.append(r)
    return np.array(co), np.array(role)


def _movements(co, role):
    x = co[:, 0]
    taper = 1.0 - 0.6 * x * x                 # the corners move less than the middle
    up, lo, chin = (role == "upper") * taper, (role == "lower") * taper, (role == "chin") * taper
    lips = up + lo
    z = np.zeros_like(co)

    def d(dx=0.0, dy=0.0, dz=0.0):
        out = z.copy()
        out[:, 0], out[:, 1], out[:, 2] = dx, dy, dz
        return out

    return {
        "jaw": d(dz=-1.0 * lo - 0.7 * chin, dy=0.1 * lo),
        # ARKit mouthClose: lips move toward each other by the jaw's drop.
        "close": d(dz=0.7 * lo - 0.3 * up, dy=-0.07 * lo),
        "round": d(dx=-0.3 * x * (lips > 0), dy=-0.2 * lips),
        "funnel": d(dx=-0.25 * x * (lips > 0), dy=-0.2 * lips, dz=0.1 * up - 0.1 * lo),
        "spread": d(dx=0.2 * x * (lips > 0)),
        "smile": d(dx=0.1 * x * (lips > 0), dz=0.1 * x * x * (lips > 0)),
        "press": d(dz=0.01 * lo - 0.01 * up),
        "tuck": d(dz=0.02 * lo + 0.05 * up, dy=0.1 * lo),
        "upper_up": d(dz=0.15 * up),
        "lower_down": d(dz=-0.15 * lo),
        "lip_open": d(dz=0.08 * up - 0.08 * lo),
    }


def _faces():
    n = len(COLUMNS)
    out = []
    for r in range(len(ROWS) - 1):
        if r == 1:
            continue  # the mouth line: upper and lower lip are separate
        for c in range(n - 1):
            a = r * n + c
            out.append((a, a + 1, a + n + 1, a + n))
    return out


def build_head(name: str, keys: dict[str, dict[str, float]]):
    """A head whose shape keys are ``keys`` (name -> movement mix), in order."""
    co, role = _layout()
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(p) for p in co], [], _faces())
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    moves = _movements(co, role)
    obj.shape_key_add(name="Basis", from_mix=False)
    for key_name, mix in keys.items():
        kb = obj.shape_key_add(name=key_name, from_mix=False)
        disp = sum((w * moves[m] for m, w in mix.items()), np.zeros_like(co))
        kb.data.foreach_set("co", (co + disp).ravel())
        kb.value = 0.0
    return obj


def _coords(obj, depsgraph) -> np.ndarray:
    ev = obj.evaluated_get(depsgraph)
    mesh = ev.to_mesh()
    co = np.empty(3 * len(mesh.vertices))
    mesh.vertices.foreach_get("co", co)
    ev.to_mesh_clear()
    return co.reshape(-1, 3)


class Opening:
    """The mouth opening of ``obj`` along its open shape ``open_key``.

    ``among``: the vertices the lips are looked for in (all by default).  On
    a sculpted head the open shape also carries the chin, the lower teeth
    and the tongue, sometimes further than the lower lip: there ``among``
    is the lips' own vertices (a vertex group), so the most-moved vertices
    are the lower lip's and the still ones facing them the upper lip's.
    """

    def __init__(self, obj, open_key: str, share: float = 0.8, among=None):
        kb = obj.data.shape_keys.key_blocks
        n = len(obj.data.vertices)
        basis, opened = np.empty(3 * n), np.empty(3 * n)
        kb[0].data.foreach_get("co", basis)
        kb[open_key].data.foreach_get("co", opened)
        self.obj, self.basis = obj, basis.reshape(-1, 3)
        delta = opened.reshape(-1, 3) - self.basis
        size = np.linalg.norm(delta, axis=1)
        if among is not None:
            outside = np.ones(n, dtype=bool)
            outside[np.asarray(among, dtype=int)] = False
            size[outside] = np.nan
        top = np.nanmax(size)
        # The open shape's most-moved vertices (the lower lip) ...
        self.lower = np.flatnonzero(size >= share * top)
        self.dir = delta[self.lower].mean(axis=0)
        self.dir /= np.linalg.norm(self.dir)
        # ... and, for each, the nearest vertex the open shape hardly moves (the upper lip facing it).
        still = np.flatnonzero(size < 0.2 * top)
        dist = np.linalg.norm(self.basis[self.lower][:, None, :] - self.basis[still][None, :, :], axis=2)
        self.upper = still[np.argmin(dist, axis=1)]
        self.unit = self._gap(delta)

    def _gap(self, disp: np.ndarray) -> float:
        return float((disp[self.lower] @ self.dir).mean() - (disp[self.upper] @ self.dir).mean())

    def at(self, frame: int) -> float:
        scene = bpy.context.scene
        scene.frame_set(frame)
        co = _coords(self.obj, bpy.context.evaluated_depsgraph_get())
        return self._gap(co - self.basis) / self.unit

    def track(self, frames) -> np.ndarray:
        return np.array([self.at(int(f)) for f in frames])


BILABIALS = {"P", "B", "M"}
OPEN_VOWELS = {"AA", "AE", "AH", "AO", "AW", "AY"}
FPS = 30


def span_frames(p, first=1):
    """Frames whose time lies inside phone ``p`` (the nearest one if none)."""
    lo, hi = int(np.ceil(p.start * FPS - 1e-9)), int(np.floor(p.end * FPS + 1e-9))
    if hi < lo:
        lo = hi = int(round((p.start + p.end) / 2 * FPS))
    return [first + f for f in range(lo, hi + 1)]


def measure(obj, open_key, phones, first=1, among=None):
    """(openings at each /p b m/, peak opening of each open vowel, lowest
    opening anywhere) of a line keyed from frame ``first``; ``among`` as
    for :class:`Opening`."""
    opening = Opening(obj, open_key, among=among)
    closed = [max(abs(v) for v in opening.track(span_frames(p, first))) for p in phones if p.phone in BILABIALS]
    # Vowels of two frames or more: a 50 ms vowel between two closures (the
    # "u" of a fast "pumpkin") barely opens the lips at 30 fps, as in life.
    vowels = [max(opening.track(span_frames(p, first))) for p in phones
              if p.phone in OPEN_VOWELS and p.end - p.start >= 2 / FPS]
    last = int(np.ceil(phones[-1].end * FPS)) + first
    lowest = float(opening.track(range(first, last + 1)).min())
    return np.array(closed), np.array(vowels), lowest


# --- heads as the conventions build them ------------------------------------------

OCULUS_POSES = {
    "sil": {}, "PP": {"press": 1.0}, "FF": {"tuck": 1.0}, "TH": {"jaw": 0.25, "spread": 0.1},
    "DD": {"jaw": 0.2, "spread": 0.2}, "kk": {"jaw": 0.3, "spread": 0.1}, "CH": {"jaw": 0.15, "funnel": 0.6},
    "SS": {"jaw": 0.08, "spread": 0.5, "smile": 0.2}, "nn": {"jaw": 0.2, "spread": 0.1},
    "RR": {"jaw": 0.15, "round": 0.5}, "aa": {"jaw": 1.0}, "E": {"jaw": 0.5, "spread": 0.5},
    "ih": {"jaw": 0.3, "spread": 0.7}, "oh": {"jaw": 0.6, "round": 0.7}, "ou": {"jaw": 0.15, "round": 1.0},
}

ARKIT_POSES = {
    "jawOpen": {"jaw": 1.0}, "mouthClose": {"close": 1.0}, "mouthFunnel": {"funnel": 1.0},
    "mouthPucker": {"round": 1.0}, "mouthSmileLeft": {"smile": 0.5}, "mouthSmileRight": {"smile": 0.5},
    "mouthStretchLeft": {"spread": 0.5}, "mouthStretchRight": {"spread": 0.5}, "mouthPressLeft": {"press": 0.5},
    "mouthPressRight": {"press": 0.5}, "mouthRollLower": {"tuck": 1.0}, "mouthRollUpper": {"press": 0.5},
    "mouthLowerDownLeft": {"lower_down": 0.5}, "mouthLowerDownRight": {"lower_down": 0.5},
    "mouthUpperUpLeft": {"upper_up": 0.5}, "mouthUpperUpRight": {"upper_up": 0.5},
    "mouthShrugUpper": {"upper_up": 0.2}, "mouthShrugLower": {"press": 0.2},
    "mouthDimpleLeft": {"spread": 0.2}, "mouthDimpleRight": {"spread": 0.2},
}
FIVE_VOWELS = {"A": {"jaw": 1.0}, "I": {"jaw": 0.3, "spread": 0.7}, "U": {"jaw": 0.15, "round": 1.0},
               "E": {"jaw": 0.5, "spread": 0.5}, "O": {"jaw": 0.6, "round": 0.7}}


#: Character Creator 4's lip and tongue visemes (the tongue is not on this mesh).
CC_LIPS = {"V_Open": {"jaw": 0.9}, "V_Explosive": {"press": 1.0}, "V_Dental_Lip": {"tuck": 1.0},
           "V_Tight_O": {"jaw": 0.4, "round": 0.8}, "V_Tight": {"round": 1.0}, "V_Wide": {"jaw": 0.15, "spread": 0.8},
           "V_Affricate": {"jaw": 0.15, "funnel": 0.7}, "V_Lip_Open": {"lip_open": 1.0}}
CC_TONGUE = {f"V_Tongue_{t}": {} for t in ("up", "Raise", "Out", "Narrow", "Lower", "Curl_U", "Curl_D")}


def arkit_keys(rename=lambda n: n) -> dict[str, dict[str, float]]:
    return {rename(n): ARKIT_POSES.get(n, {}) for n in ARKIT_52}


def oculus_keys(names: dict[str, str]) -> dict[str, dict[str, float]]:
    """Oculus poses under the rig's own names (viseme -> key name)."""
    return {names[v]: pose for v, pose in OCULUS_POSES.items()}


def _cc_arkit_name(n: str, k: int) -> str:
    """Character Creator's numbered ARKit-style names: A25_Jaw_Open."""
    import re

    words = re.sub(r"([A-Z])", r" \1", n).split()
    return f"A{k + 1:02d}_" + "_".join(w[0].upper() + w[1:] for w in words)


#: Ready Player Me spells three Oculus visemes its own way.
RPM_SPELLING = {"ih": "I", "oh": "O", "ou": "U"}

HEADS = {
    # name: (shape keys, the open shape measured against)
    "ready_player_me": ({**oculus_keys({v: "viseme_" + RPM_SPELLING.get(v, v) for v in OCULUS_POSES}),
                         **arkit_keys()}, "viseme_aa"),
    "oculus": (oculus_keys({v: f"viseme_{v}" for v in OCULUS_POSES}), "viseme_aa"),
    "vrchat": (oculus_keys({v: f"vrc.v_{v.lower()}" for v in OCULUS_POSES}), "vrc.v_aa"),
    "arkit": (arkit_keys(), "jawOpen"),
    "arkit_pascal_prefixed": (arkit_keys(lambda n: "Head." + n[0].upper() + n[1:]), "Head.JawOpen"),
    "arkit_cc_numbered": ({_cc_arkit_name(n, k): ARKIT_POSES.get(n, {}) for k, n in enumerate(ARKIT_52)},
                          _cc_arkit_name("jawOpen", ARKIT_52.index("jawOpen"))),
    "vroid": ({**{f"Fcl_MTH_{v}": p for v, p in FIVE_VOWELS.items()},
               "Fcl_MTH_Close": {"press": 1.0}, "Fcl_MTH_Up": {"smile": 0.5}, "Fcl_MTH_Down": {"upper_up": 0.2},
               "Fcl_MTH_Angry": {"press": 0.5}, "Fcl_MTH_Small": {"round": 0.4}, "Fcl_MTH_Large": {"spread": 0.4},
               "Fcl_MTH_Neutral": {}, "Fcl_MTH_Fun": {"smile": 1.0}, "Fcl_MTH_Joy": {"jaw": 0.4, "smile": 1.0},
               "Fcl_MTH_Sorrow": {"press": 0.3}, "Fcl_MTH_Surprised": {"jaw": 0.6, "round": 0.3},
               "Fcl_EYE_Close": {}, "Fcl_BRW_Angry": {}}, "Fcl_MTH_A"),
    "vrm0": ({**FIVE_VOWELS, "Blink": {}, "Joy": {"smile": 1.0}, "Angry": {"press": 0.5}}, "A"),
    "vrm1": ({"aa": FIVE_VOWELS["A"], "ih": FIVE_VOWELS["I"], "ou": FIVE_VOWELS["U"], "ee": FIVE_VOWELS["E"],
              "oh": FIVE_VOWELS["O"], "happy": {"smile": 1.0}, "blink": {}}, "aa"),
    "mmd": ({"あ": FIVE_VOWELS["A"], "い": FIVE_VOWELS["I"], "う": FIVE_VOWELS["U"], "え": FIVE_VOWELS["E"],
             "お": FIVE_VOWELS["O"], "まばたき": {}}, "あ"),
    "character_creator_4": ({**CC_LIPS, **CC_TONGUE,
                             **{_cc_arkit_name(n, k): ARKIT_POSES.get(n, {}) for k, n in enumerate(ARKIT_52)}},
                            "V_Open"),
    "character_creator_3": ({{"V_Tight_O": "Tight-O", "V_Tongue_Curl_U": "Tongue_Curl-U",
                              "V_Tongue_Curl_D": "Tongue_Curl-D"}.get(k, k[2:]): p
                             for k, p in {**CC_LIPS, **CC_TONGUE}.items()}, "Open"),
    "iclone_direct": ({"AE": {"jaw": 0.6, "spread": 0.4}, "Ah": {"jaw": 1.0}, "B_M_P": {"press": 1.0},
                       "Ch_J": {"jaw": 0.15, "funnel": 0.6}, "EE": {"jaw": 0.2, "spread": 0.8},
                       "Er": {"jaw": 0.2, "round": 0.4}, "F_V": {"tuck": 1.0}, "IH": {"jaw": 0.3, "spread": 0.6},
                       "K_G_H_NG": {"jaw": 0.3}, "Oh": {"jaw": 0.6, "round": 0.7}, "R": {"jaw": 0.15, "round": 0.5},
                       "S_Z": {"jaw": 0.08, "spread": 0.5}, "T_L_D_N": {"jaw": 0.2, "spread": 0.2},
                       "TH": {"jaw": 0.25}, "W_OO": {"jaw": 0.1, "round": 1.0}, "None": {}}, "Ah"),
    "mpfb_microsoft": ({"sil_00": {}, "aa_ah_ax_01": {"jaw": 0.7}, "aa_02": {"jaw": 1.0},
                        "ao_03": {"jaw": 0.7, "round": 0.4}, "ey_eh_uh_04": {"jaw": 0.5, "spread": 0.4},
                        "er_05": {"jaw": 0.2, "round": 0.4}, "y_iy_ih_ix_06": {"jaw": 0.25, "spread": 0.7},
                        "w_uw_07": {"jaw": 0.1, "round": 1.0}, "ow_08": {"jaw": 0.5, "round": 0.7},
                        "aw_09": {"jaw": 0.8, "round": 0.3}, "oy_10": {"jaw": 0.5, "round": 0.5},
                        "ay_11": {"jaw": 0.9, "spread": 0.2}, "h_12": {"jaw": 0.4}, "r_13": {"jaw": 0.15, "round": 0.5},
                        "l_14": {"jaw": 0.3}, "s_z_15": {"jaw": 0.08, "spread": 0.5},
                        "sh_ch_jh_zh_16": {"jaw": 0.15, "funnel": 0.6}, "th_dh_17": {"jaw": 0.25},
                        "f_v_18": {"tuck": 1.0}, "d_t_n_19": {"jaw": 0.2, "spread": 0.2}, "k_g_ng_20": {"jaw": 0.3},
                        "p_b_m_21": {"press": 1.0}}, "aa_02"),
    "daz_genesis_8": ({f"eCTRLv{k}": p for k, p in {
        "AA": {"jaw": 1.0}, "EE": {"jaw": 0.2, "spread": 0.8}, "EH": {"jaw": 0.5, "spread": 0.4},
        "ER": {"jaw": 0.2, "round": 0.4}, "F": {"tuck": 1.0}, "IH": {"jaw": 0.3, "spread": 0.6},
        "IY": {"jaw": 0.2, "spread": 0.8}, "K": {"jaw": 0.3}, "L": {"jaw": 0.3}, "M": {"press": 1.0},
        "OW": {"jaw": 0.5, "round": 0.7}, "S": {"jaw": 0.08, "spread": 0.5}, "SH": {"jaw": 0.15, "funnel": 0.6},
        "T": {"jaw": 0.2, "spread": 0.2}, "TH": {"jaw": 0.25}, "UW": {"jaw": 0.1, "round": 1.0},
        "W": {"round": 1.0}}.items()}, "eCTRLvAA"),
    "preston_blair": ({"rest": {}, "MBP": {"press": 1.0}, "FV": {"tuck": 1.0}, "L": {"jaw": 0.35},
                       "etc": {"jaw": 0.25, "spread": 0.3}, "WQ": {"round": 1.0}, "AI": {"jaw": 1.0},
                       "E": {"jaw": 0.5, "spread": 0.5}, "O": {"jaw": 0.6, "round": 0.7},
                       "U": {"jaw": 0.15, "round": 1.0}}, "AI"),
    "rhubarb": ({"mouth_X": {}, "mouth_A": {"press": 1.0}, "mouth_B": {"jaw": 0.15, "spread": 0.3},
                 "mouth_C": {"jaw": 0.5, "spread": 0.3}, "mouth_D": {"jaw": 1.0},
                 "mouth_E": {"jaw": 0.4, "round": 0.6}, "mouth_F": {"jaw": 0.1, "round": 1.0},
                 "mouth_G": {"tuck": 1.0}, "mouth_H": {"jaw": 0.4}}, "mouth_D"),
}
