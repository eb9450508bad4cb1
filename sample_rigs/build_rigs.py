"""Two sample characters, built procedurally, for trying and testing the add-on.

* **Ada** has one shape key per viseme of the default set (``MBP``, ``FV``,
  ``AHH``, ``OHH``, ...), the way hand-made cartoon rigs are often set up.
* **Kit** has ARKit-named blendshapes (``jawOpen``, ``mouthClose``,
  ``mouthFunnel``, ``mouthPucker``, ``mouthStretchLeft`` ...) on a closed
  mouth, as an iPhone-captured head has them: ``mouthClose`` brings the lips
  together on an open jaw.

Each head is a sphere with a ring of lips and a dark mouth interior; every
shape key is a mix of a few mouth movements (jaw open, lips closed, lips
rounded, corners wide or raised, lower lip tucked), so the keys look like
what their names say.  Run with Blender's Python::

    .venv/bin/python sample_rigs/build_rigs.py OUT.blend
"""

from __future__ import annotations

import math
import sys

import bmesh
import bpy
import numpy as np

HEAD_R = 1.0
MOUTH_Z = -0.38          # mouth centre height on the head
MOUTH_W = 0.30           # half width
MOUTH_H = 0.05           # half height of the rest opening
LIP_R = 0.045            # lip thickness

# Movements: each maps rest positions (n, 3) and per-vertex mouth
# coordinates to displacements (n, 3).


def _movements(co, u, v, part):
    """``u``: -1..1 across the mouth (character's right to left); ``v``:
    -1 (lower lip) .. 1 (upper lip); ``part``: 0 head, 1 lips, 2 inside."""
    mouth = (part > 0).astype(float)
    lower = np.clip((1 - v) / 2, 0, 1) * mouth
    upper = np.clip((1 + v) / 2, 0, 1) * mouth
    # The jaw carries the chin: head vertices below the mouth, near the front.
    below = np.clip((MOUTH_Z - co[:, 2]) / 0.25, 0, 1) * np.clip(-co[:, 1] / HEAD_R, 0, 1) ** 2 \
        * np.clip(1 - np.abs(co[:, 0]) / 0.75, 0, 1) * (part == 0) \
        * np.clip((co[:, 2] + HEAD_R) / 0.5, 0, 1) ** 2  # the chin moves, the neck does not
    jaw = np.maximum(lower, below)
    z = np.zeros_like(co)

    def d(dx=0.0, dy=0.0, dz=0.0):
        out = z.copy()
        out[:, 0], out[:, 1], out[:, 2] = dx, dy, dz
        return out

    side_l = np.clip(0.5 + u, 0, 1) * mouth
    side_r = np.clip(0.5 - u, 0, 1) * mouth
    corner = np.abs(u) ** 2 * mouth
    return {
        "open": d(dz=-0.32 * jaw, dy=0.05 * jaw),
        "close": d(dz=-(MOUTH_H + 0.004) * v * mouth),
        "wide": d(dx=0.12 * u * mouth),
        "round": d(dx=-0.14 * u * mouth, dy=-0.09 * mouth * (1 - 0.5 * np.abs(v)), dz=0.02 * v * mouth),
        "smile_l": d(dx=0.04 * u * side_l, dz=0.08 * corner * side_l),
        "smile_r": d(dx=0.04 * u * side_r, dz=0.08 * corner * side_r),
        "frown_l": d(dz=-0.07 * corner * side_l),
        "frown_r": d(dz=-0.07 * corner * side_r),
        "stretch_l": d(dx=0.08 * u * side_l, dz=-0.02 * corner * side_l),
        "stretch_r": d(dx=0.08 * u * side_r, dz=-0.02 * corner * side_r),
        "tuck_lower": d(dz=(MOUTH_H + 0.03) * lower * (1 - np.abs(u)), dy=0.035 * lower),
        "roll_upper": d(dz=-(MOUTH_H * 0.8) * upper * (1 - np.abs(u)), dy=0.03 * upper),
        "upper_up_l": d(dz=0.05 * upper * side_l * (1 - np.abs(u))),
        "upper_up_r": d(dz=0.05 * upper * side_r * (1 - np.abs(u))),
        "lower_down_l": d(dz=-0.05 * lower * side_l * (1 - np.abs(u))),
        "lower_down_r": d(dz=-0.05 * lower * side_r * (1 - np.abs(u))),
        "shift_l": d(dx=0.06 * mouth),
        "shift_r": d(dx=-0.06 * mouth),
        "jaw_fwd": d(dy=-0.06 * jaw),
        "jaw_l": d(dx=0.08 * jaw),
        "jaw_r": d(dx=-0.08 * jaw),
        "shrug_upper": d(dz=0.03 * upper),
        "shrug_lower": d(dz=0.04 * lower, dy=-0.02 * lower),
        "press": d(dz=-0.4 * (MOUTH_H + 0.004) * v * mouth, dx=0.02 * u * mouth),
        # ARKit's mouthClose: the lips move toward each other by as much as
        # the jaw drops them apart, so they meet on an open jaw.
        "close_jaw": d(dz=0.32 * (0.7 * lower - 0.3 * upper), dy=-0.05 * 0.7 * lower),
    }


#: Ada: the default viseme set, one shape key per viseme.
DEFAULT_KEYS = {
    "MBP": {"close": 1.0, "press": 0.3},
    "FV": {"tuck_lower": 1.0, "upper_up_l": 0.3, "upper_up_r": 0.3},
    "TH": {"open": 0.22, "wide": 0.15},
    "TD": {"open": 0.18, "wide": 0.2},
    "SZ": {"open": 0.06, "wide": 0.45, "smile_l": 0.2, "smile_r": 0.2},
    "SH": {"round": 0.55, "open": 0.15, "shrug_upper": 0.5},
    "GK": {"open": 0.3, "wide": 0.1},
    "L": {"open": 0.32},
    "R": {"round": 0.45, "open": 0.12},
    "AHH": {"open": 0.85, "wide": 0.15},
    "EH": {"open": 0.5, "wide": 0.45},
    "IEE": {"open": 0.18, "wide": 0.65, "smile_l": 0.4, "smile_r": 0.4},
    "OHH": {"open": 0.55, "round": 0.7},
    "UUU": {"open": 0.12, "round": 1.0},
}

#: Kit: the mouth and jaw blendshapes of ARKit's 52, on a closed-mouth
#: basis (:data:`ARKIT_BASIS`) as ARKit defines them.
ARKIT_BASIS = {"close": 1.0}
ARKIT_KEYS = {
    "jawOpen": {"open": 1.0}, "jawForward": {"jaw_fwd": 1.0}, "jawLeft": {"jaw_l": 1.0},
    "jawRight": {"jaw_r": 1.0}, "mouthClose": {"close_jaw": 1.0}, "mouthFunnel": {"round": 0.7, "open": 0.15},
    "mouthPucker": {"round": 1.0}, "mouthLeft": {"shift_l": 1.0}, "mouthRight": {"shift_r": 1.0},
    "mouthSmileLeft": {"smile_l": 1.0}, "mouthSmileRight": {"smile_r": 1.0},
    "mouthFrownLeft": {"frown_l": 1.0}, "mouthFrownRight": {"frown_r": 1.0},
    "mouthDimpleLeft": {"smile_l": 0.3, "stretch_l": 0.3}, "mouthDimpleRight": {"smile_r": 0.3, "stretch_r": 0.3},
    "mouthStretchLeft": {"stretch_l": 1.0}, "mouthStretchRight": {"stretch_r": 1.0},
    "mouthRollLower": {"tuck_lower": 1.0}, "mouthRollUpper": {"roll_upper": 1.0},
    "mouthShrugLower": {"shrug_lower": 1.0}, "mouthShrugUpper": {"shrug_upper": 1.0},
    "mouthPressLeft": {"press": 0.5}, "mouthPressRight": {"press": 0.5},
    "mouthLowerDownLeft": {"lower_down_l": 1.0}, "mouthLowerDownRight": {"lower_down_r": 1.0},
    "mouthUpperUpLeft": {"upper_up_l": 1.0}, "mouthUpperUpRight": {"upper_up_r": 1.0},
    "tongueOut": {"open": 0.2},
}


def _material(name, rgba):
    mat = bpy.data.materials.get(name) or bpy.data.materials.new(name)
    mat.diffuse_color = rgba
    return mat


def _head_surface_y(x, z):
    return -math.sqrt(max(HEAD_R ** 2 - x * x - z * z, 0.0))


def build_mesh(name: str) -> bpy.types.Mesh:
    """Head, lips and mouth interior in one mesh, with a part id per vertex."""
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=48, v_segments=32, radius=HEAD_R)
    part_of = bm.verts.layers.int.new("mouth_part")  # 0 head, 1 lips, 2 inside of the mouth
    for f in bm.faces:
        f.material_index = 0
    # Lips: an elliptical tube around the mouth opening.
    n_t, n_p = 40, 8
    ring = []
    for i in range(n_t):
        t = 2 * math.pi * i / n_t
        cx, cz = MOUTH_W * math.cos(t), MOUTH_Z + (MOUTH_H + LIP_R) * math.sin(t)
        cy = _head_surface_y(cx, cz) - 0.015
        nx, nz = math.cos(t), math.sin(t)  # outward in the face plane
        row = []
        for j in range(n_p):
            p = 2 * math.pi * j / n_p
            r_in = LIP_R * (1.0 if math.sin(t) >= 0 else 1.2)
            vert = bm.verts.new((cx + r_in * math.cos(p) * nx, cy - r_in * math.sin(p),
                                 cz + r_in * math.cos(p) * nz))
            vert[part_of] = 1
            row.append(vert)
        ring.append(row)
    for i in range(n_t):
        for j in range(n_p):
            f = bm.faces.new((ring[i][j], ring[(i + 1) % n_t][j], ring[(i + 1) % n_t][(j + 1) % n_p],
                              ring[i][(j + 1) % n_p]))
            f.material_index = 1
    # Inside of the mouth: a dark disc just behind the lips.
    centre = bm.verts.new((0.0, _head_surface_y(0, MOUTH_Z) + 0.02, MOUTH_Z))
    centre[part_of] = 2
    rim = []
    for i in range(n_t):
        t = 2 * math.pi * i / n_t
        x, z = MOUTH_W * 1.02 * math.cos(t), MOUTH_Z + (MOUTH_H + LIP_R) * math.sin(t)
        rim.append(bm.verts.new((x, _head_surface_y(x, z) + 0.02, z)))
        rim[-1][part_of] = 2
    for i in range(n_t):
        f = bm.faces.new((centre, rim[(i + 1) % n_t], rim[i]))
        f.material_index = 2
    mesh = bpy.data.meshes.new(name)
    bm.to_mesh(mesh)
    bm.free()
    for poly in mesh.polygons:
        poly.use_smooth = True
    for mat in (_material("Skin", (0.93, 0.72, 0.6, 1)), _material("Lips", (0.72, 0.3, 0.32, 1)),
                _material("Mouth", (0.12, 0.03, 0.04, 1))):
        mesh.materials.append(mat)
    return mesh


def _mouth_coords(mesh):
    n = len(mesh.vertices)
    co = np.empty(n * 3)
    mesh.vertices.foreach_get("co", co)
    co = co.reshape(n, 3)
    part = np.empty(n, dtype=np.int32)
    mesh.attributes["mouth_part"].data.foreach_get("value", part)
    u = np.clip(co[:, 0] / MOUTH_W, -1, 1)
    v = np.clip((co[:, 2] - MOUTH_Z) / (MOUTH_H + LIP_R), -1, 1)
    return co, u, v, part


def build_character(name: str, keys: dict[str, dict[str, float]], location=(0.0, 0.0, 0.0),
                    basis: dict[str, float] | None = None):
    """A head with ``keys`` (name -> mix of movements); ``basis`` moves the
    rest shape itself (a closed mouth for ARKit)."""
    mesh = build_mesh(name)
    obj = bpy.data.objects.new(name, mesh)
    obj.location = location
    bpy.context.scene.collection.objects.link(obj)
    co, u, v, part = _mouth_coords(mesh)
    moves = _movements(co, u, v, part)
    if basis:
        co = co + sum(w * moves[m] for m, w in basis.items())
        mesh.vertices.foreach_set("co", co.ravel())
    obj.shape_key_add(name="Basis", from_mix=False)
    for key_name, mix in keys.items():
        kb = obj.shape_key_add(name=key_name, from_mix=False)
        disp = sum(w * moves[m] for m, w in mix.items())
        kb.data.foreach_set("co", (co + disp).ravel())
        kb.value = 0.0
    for side in (-1, 1):  # eyes, so the head reads as a face
        eye = bpy.data.objects.new(f"{name}_eye_{'L' if side > 0 else 'R'}", _eye_mesh())
        eye.parent = obj
        eye.location = (0.33 * side, -0.86, 0.25)
        bpy.context.scene.collection.objects.link(eye)
    return obj


def _eye_mesh():
    mesh = bpy.data.meshes.get("SampleEye")
    if mesh is None:
        bm = bmesh.new()
        bmesh.ops.create_uvsphere(bm, u_segments=16, v_segments=10, radius=0.11)
        mesh = bpy.data.meshes.new("SampleEye")
        bm.to_mesh(mesh)
        bm.free()
        mesh.materials.append(_material("Eye", (0.05, 0.05, 0.08, 1)))
    return mesh


def build_scene():
    """A new file with Ada (default set) and Kit (ARKit) and a camera, ready
    to render with Workbench."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return build_scene_objects()


def build_scene_objects():
    """Ada, Kit and a camera in the current scene."""
    scene = bpy.context.scene
    ada = build_character("Ada", DEFAULT_KEYS, (-1.25, 0, 0))
    kit = build_character("Kit", ARKIT_KEYS, (1.25, 0, 0), basis=ARKIT_BASIS)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location = (0, -7.5, -0.1)
    cam.rotation_euler = (math.radians(90), 0, 0)
    cam.data.lens = 50
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.display.shading.color_type = "MATERIAL"
    scene.display.shading.light = "STUDIO"
    scene.render.resolution_x, scene.render.resolution_y = 480, 270
    scene.render.fps, scene.render.fps_base = 30, 1.0
    return ada, kit


def main(argv):
    if len(argv) != 1:
        print("usage: build_rigs.py OUT.blend", file=sys.stderr)
        return 2
    build_scene()
    bpy.ops.wm.save_as_mainfile(filepath=argv[0])
    print(f"wrote {argv[0]}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
