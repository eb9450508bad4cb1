"""The route to game engines: a character imported from glTF is lip-synced
and exported again, glTF (morph-target weights animation) and FBX (baked
shape-key animation); the exported files are read back and must carry the
keys the extension wrote, at the right times.

The characters are the sample rigs (``Ada``: the default viseme set, ``Kit``:
ARKit blendshapes), written to a ``.glb`` with Blender's own exporter and
imported into an empty file, so the mesh, its shape keys and their names are
what the glTF importer makes of them, as for a downloaded character.

The exporters' options changed between Blender 4.2 and 5.2; only the options
the running exporter has are passed (``_call``).  What the files must say:

* glTF: the mesh node's ``weights`` channel has one weight per morph target
  (in the order of ``mesh.extras.targetNames``, the shape keys' order) per
  key, its times are the frames' times (frame f at f / fps, so the first is
  the strip's start), and the weights are the F-curves' values there.
* FBX: re-imported, the shape-key F-curves are the originals.  Blender
  writes frame f at f / fps and its importer adds ``anim_offset`` frames (1
  by default, for files from programs counting from 0), so a Blender-to-
  Blender round trip needs ``anim_offset=0``.
* Both: the lips still close on each /p b m/ of the line.
"""

from __future__ import annotations

import json
import os
import struct
from importlib import import_module

import addon_utils
import bpy
import numpy as np
import pytest

from conftest import FIXTURES, MODULE, add_strip, fcurve_values, keyed_shape_keys

BOB = os.path.join(FIXTURES, "bob_map.wav")
BOB_TEXT = "Bob bought a map."
BILABIALS = {"P", "B", "M"}
START = 13    # the strip's first frame: not the scene start, so offsets show
FPS = 24      # not the sample rigs' 30, so a frame/second mix-up shows
# The lip-closing shape key and the key it closes against (see _assert_lips_close).
CLOSING = {"Ada": ("MBP", None), "Kit": ("mouthClose", "jawOpen")}


# --- helpers ---------------------------------------------------------------------

def _enable(module):
    """The bundled importer/exporter add-on, enabled."""
    if not addon_utils.check(module)[1]:
        addon_utils.enable(module, default_set=True)
    assert addon_utils.check(module)[1], f"{module} cannot be enabled"


def _call(op, **wanted):
    """Run an import/export operator with the options of ``wanted`` that
    this Blender's version of it has (an enum value it lacks is left out
    too; a dynamic enum, such as the glTF ``export_format``, lists no items
    here and its value is passed as is).  Returns the options passed."""
    props = {p.identifier: p for p in op.get_rna_type().properties}
    kw = {}
    for name, value in wanted.items():
        prop = props.get(name)
        if prop is None:
            continue
        items = {i.identifier for i in prop.enum_items} if prop.type == "ENUM" else None
        if items:
            if not ({value} if isinstance(value, str) else set(value)) <= items:
                continue
        kw[name] = value
    assert op("EXEC_DEFAULT", **kw) == {"FINISHED"}
    return kw


def _fps(scene):
    return scene.render.fps / scene.render.fps_base


def _visible(strip):
    """First and end frame of a strip's visible part (``left_handle`` and
    ``right_handle`` since 5.1, which deprecated ``frame_final_start`` and
    ``frame_final_end``)."""
    if hasattr(strip, "left_handle"):
        return strip.left_handle, strip.right_handle
    return strip.frame_final_start, strip.frame_final_end


def _alignment(text):
    """Phone times of the fixture, from the audio as Blender decodes it (as
    the operator does)."""
    decoded = import_module(MODULE + ".blender.sources").decode(BOB)
    return import_module(MODULE + ".engine.pipeline").align_audio(decoded, text)


def _assert_lips_close(t, weights, rig, fps):
    """The lips open in the line and meet at each /p b m/ of "Bob bought a
    map" (give or take a frame).  ``weights``: shape key -> weights at
    seconds ``t`` from the line's start, as read back from a file.

    Ada's ``MBP`` closes the lips at full strength, so they meet where it
    is near the highest value keyed on it (within 20 %: at 24 fps a /p/
    shorter than a frame, as the last one may be, is sampled off its peak).  ARKit's ``mouthClose`` closes
    the lips of an open jaw: they meet when it reaches ``jawOpen`` (the
    extension keys it as closure x ``jawOpen``), so Kit's lips meet where
    ``mouthClose`` is (nearly) ``jawOpen``: the gap between them near 0 and
    ``mouthClose`` most of ``jawOpen``, on one frame."""
    key, relative = CLOSING[rig]
    close = weights[key]
    if relative is None:
        gap = close.max() - close
        scale = close.max()
        closed = gap <= 0.2 * scale
    else:
        gap = weights[relative] - close
        scale = weights[relative].max()
        closed = (gap <= 0.2 * scale) & (close >= 0.8 * weights[relative])
    assert scale >= 0.3, f"{relative or key} hardly moves"
    assert gap.max() >= 0.3 * scale, "the lips never open"
    bilabials = [p for p in _alignment(BOB_TEXT).phones if p.phone in BILABIALS]
    assert len(bilabials) >= 3  # B-o-b, m-ap
    for p in bilabials:
        window = (t >= p.start - 1 / fps) & (t <= p.end + 1 / fps)
        assert window.any()
        assert closed[window].any(), f"lips open during /{p.phone}/ at {p.start:.2f}s"


# --- glTF files, read with plain Python ------------------------------------------

_COMPONENTS = {5126: ("f", 4)}  # float: the only type the exporter writes for times and weights
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}


def _read_gltf(path):
    """(json, [buffer bytes]) of a .gltf (with its .bin) or a .glb."""
    with open(path, "rb") as fh:
        data = fh.read()
    if data[:4] == b"glTF":
        _magic, version, length = struct.unpack_from("<4sII", data, 0)
        assert version == 2 and length == len(data)
        chunks, pos = [], 12
        while pos < length:
            size, kind = struct.unpack_from("<I4s", data, pos)
            chunks.append((kind, data[pos + 8:pos + 8 + size]))
            pos += 8 + size
        assert chunks[0][0] == b"JSON"
        doc = json.loads(chunks[0][1].decode("utf-8"))
        bins = [c for k, c in chunks[1:] if k == b"BIN\x00"]
        buffers = [bins[0] if "uri" not in b else None for b in doc.get("buffers", [])]
    else:
        doc = json.loads(data.decode("utf-8"))
        buffers = []
    base = os.path.dirname(path)
    for i, b in enumerate(doc.get("buffers", [])):
        if "uri" in b:
            assert not b["uri"].startswith("data:"), "embedded buffers are not expected"
            with open(os.path.join(base, b["uri"]), "rb") as fh:
                blob = fh.read()
            if i < len(buffers):
                buffers[i] = blob
            else:
                buffers.append(blob)
    return doc, buffers


def _accessor(doc, buffers, index):
    """An accessor's values as a (count, width) float array."""
    acc = doc["accessors"][index]
    code, size = _COMPONENTS[acc["componentType"]]
    width = _WIDTH[acc["type"]]
    view = doc["bufferViews"][acc["bufferView"]]
    blob = buffers[view["buffer"]]
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    stride = view.get("byteStride", size * width)
    out = np.empty((acc["count"], width))
    for k in range(acc["count"]):
        out[k] = struct.unpack_from("<" + code * width, blob, start + k * stride)
    return out


def _morph_animation(doc, buffers, node_name):
    """(target names, times (n,), weights (n, targets), interpolation) of the
    one animation channel driving the named node's morph weights."""
    nodes = [i for i, n in enumerate(doc["nodes"]) if n.get("name") == node_name]
    assert len(nodes) == 1, f"node {node_name!r} in {[n.get('name') for n in doc['nodes']]}"
    node = doc["nodes"][nodes[0]]
    mesh = doc["meshes"][node["mesh"]]
    names = mesh["extras"]["targetNames"]
    for prim in mesh["primitives"]:
        assert len(prim["targets"]) == len(names)
    found = [(anim, ch) for anim in doc.get("animations", []) for ch in anim["channels"]
             if ch["target"].get("node") == nodes[0] and ch["target"]["path"] == "weights"]
    assert len(found) == 1, f"{len(found)} weight channels for {node_name!r}"
    anim, ch = found[0]
    sampler = anim["samplers"][ch["sampler"]]
    times = _accessor(doc, buffers, sampler["input"])[:, 0]
    flat = _accessor(doc, buffers, sampler["output"])[:, 0]
    interpolation = sampler.get("interpolation", "LINEAR")
    if interpolation == "CUBICSPLINE":  # in-tangent, value, out-tangent per key
        weights = flat.reshape(len(times), 3, len(names))[:, 1, :]
    else:
        weights = flat.reshape(len(times), len(names))
    return names, times, weights, interpolation


def _sample(times, values, interpolation, at):
    """The glTF sampler's value at times ``at`` (LINEAR and STEP exactly;
    CUBICSPLINE only at its keys, which is where it is compared)."""
    if interpolation == "STEP":
        k = np.clip(np.searchsorted(times, at + 1e-6, side="right") - 1, 0, len(times) - 1)
        return values[k]
    return np.interp(at, times, values)


# --- building and importing the character ----------------------------------------

def _character_from_glb(name, tmp_path):
    """Export the sample rigs of the ``scene`` fixture to a .glb, start an
    empty file, import it; the scene (at ``FPS``) and the imported mesh
    object called ``name``."""
    _enable("io_scene_gltf2")
    glb = str(tmp_path / "characters.glb")
    _call(bpy.ops.export_scene.gltf, filepath=glb, export_format="GLB", export_morph=True,
          export_animations=False, export_cameras=False, export_lights=False)
    source_keys = [kb.name for kb in bpy.data.objects[name].data.shape_keys.key_blocks[1:]]

    bpy.ops.wm.read_homefile(use_empty=True)
    _call(bpy.ops.import_scene.gltf, filepath=glb)
    meshes = [o for o in bpy.data.objects if o.type == "MESH" and o.data.shape_keys is not None]
    assert sorted(o.name for o in meshes) == ["Ada", "Kit"]
    obj = bpy.data.objects[name]
    # The shape keys are the importer's, named from the file's targetNames.
    doc, _b = _read_gltf(glb)
    node = next(n for n in doc["nodes"] if n.get("name") == name)
    target_names = doc["meshes"][node["mesh"]]["extras"]["targetNames"]
    imported = [kb.name for kb in obj.data.shape_keys.key_blocks]
    assert imported[1:] == target_names == source_keys
    assert obj.data.shape_keys.animation_data is None

    sc = bpy.context.scene
    sc.render.fps, sc.render.fps_base = FPS, 1.0
    return sc, obj


def _lipsync(sc, obj):
    """Generate on the imported mesh, by name, from the sound strip; the
    strip's visible (first, end) frames and the keyed shape keys."""
    strip = add_strip(sc, "line", BOB, frame=START)
    assert bpy.ops.emotive_lipsync.generate("EXEC_DEFAULT", mesh=obj.name, text=BOB_TEXT) == {"FINISHED"}
    keyed = keyed_shape_keys(obj)
    assert {k for k in CLOSING[obj.name] if k} <= keyed
    first, end = _visible(strip)
    assert first == START
    return first, end, keyed


# --- glTF ------------------------------------------------------------------------

GLTF_EXPORT = dict(
    export_format="GLTF_SEPARATE",
    export_animations=True,
    export_animation_mode="ACTIONS",      # 4.0+: each action its own glTF animation
    export_morph=True,
    export_morph_animation=True,
    export_morph_normal=False,
    export_force_sampling=True,           # a sample on every frame of the action
    export_frame_step=1,
    export_frame_range=False,             # the action's range, not the scene's
    export_anim_slide_to_zero=False,      # keep frame f at f / fps
    export_negative_frame="SLIDE",
    export_optimize_animation_size=False,  # keep every sample
    export_bake_animation=False,
    export_current_frame=False,
    export_cameras=False,
    export_lights=False,
)


@pytest.mark.parametrize("name", ["Ada", "Kit"])
def test_gltf_round_trip_carries_the_lip_sync(scene, tmp_path, name):
    sc, obj = _character_from_glb(name, tmp_path)
    first, _end, keyed = _lipsync(sc, obj)
    fps = _fps(sc)

    out = str(tmp_path / "lipsync.gltf")
    _call(bpy.ops.export_scene.gltf, filepath=out, **GLTF_EXPORT)
    assert os.path.isfile(out)
    doc, buffers = _read_gltf(out)
    names, times, weights, interpolation = _morph_animation(doc, buffers, obj.name)

    key_blocks = obj.data.shape_keys.key_blocks
    assert names == [kb.name for kb in key_blocks[1:]]  # morph target i is shape key i + 1
    assert np.all(np.diff(times) > 0)
    assert times[0] == pytest.approx(first / fps, abs=1e-4)  # the strip's start, in seconds

    for name_k in keyed:
        i = names.index(name_k)
        frames, values = fcurve_values(obj, name_k)
        assert times[0] == pytest.approx(frames[0] / fps, abs=1e-4)
        assert times[-1] == pytest.approx(frames[-1] / fps, abs=1e-4)
        # The keyed values at the keys' times ...
        exported = _sample(times, weights[:, i], interpolation, frames / fps)
        assert np.abs(exported - values).max() <= 1e-3, name_k
        # ... and every exported sample on the F-curve.
        fc = import_module(MODULE + ".blender.compat").find_fcurve(obj.data.shape_keys,
                                                                  f'key_blocks["{name_k}"].value')
        curve = np.array([fc.evaluate(t * fps) for t in times])
        assert np.abs(curve - weights[:, i]).max() <= 1e-3, name_k
    # Shape keys the lip sync does not drive stay at rest.
    for name_k in set(names) - keyed:
        assert np.abs(weights[:, names.index(name_k)] - key_blocks[name_k].value).max() <= 1e-3, name_k

    # Lips close on each /p b m/ in the exported weights.
    _assert_lips_close(times - first / fps, dict(zip(names, weights.T)), obj.name, fps)


# --- FBX -------------------------------------------------------------------------

FBX_EXPORT = dict(
    object_types={"MESH"},
    use_mesh_modifiers=False,             # modifiers applied would drop the shape keys
    bake_anim=True,
    bake_anim_use_all_bones=False,
    bake_anim_use_nla_strips=False,       # one take: the scene's frame range, baked
    bake_anim_use_all_actions=False,
    bake_anim_force_startend_keying=True,
    bake_anim_step=1.0,
    bake_anim_simplify_factor=0.0,        # keep every baked frame
    add_leaf_bones=False,
)


@pytest.mark.parametrize("name", ["Ada", "Kit"])
def test_fbx_round_trip_carries_the_lip_sync(scene, tmp_path, name):
    _enable("io_scene_fbx")
    sc, obj = _character_from_glb(name, tmp_path)
    first, end, keyed = _lipsync(sc, obj)
    compat = import_module(MODULE + ".blender.compat")
    sc.frame_start, sc.frame_end = 1, end + 10  # the take FBX bakes
    frames = np.arange(sc.frame_start, sc.frame_end + 1)
    original = {}
    for name_k in keyed:
        fc = compat.find_fcurve(obj.data.shape_keys, f'key_blocks["{name_k}"].value')
        original[name_k] = np.array([fc.evaluate(f) for f in frames])
    rest = {kb.name: kb.value for kb in obj.data.shape_keys.key_blocks}

    out = str(tmp_path / "lipsync.fbx")
    _call(bpy.ops.export_scene.fbx, filepath=out, **FBX_EXPORT)
    bpy.ops.wm.read_homefile(use_empty=True)
    # FBX times are seconds from 0; Blender writes frame f at f / fps and the
    # importer adds anim_offset (1 by default, for files that count from 0).
    _call(bpy.ops.import_scene.fbx, filepath=out, use_anim=True, anim_offset=0.0)
    sc2 = bpy.context.scene
    assert _fps(sc2) == pytest.approx(FPS)  # the file's frame rate
    back = bpy.data.objects[name]
    assert [kb.name for kb in back.data.shape_keys.key_blocks] == list(rest)
    assert keyed <= keyed_shape_keys(back)
    reimported = {}
    for name_k in keyed_shape_keys(back):
        fc = compat.find_fcurve(back.data.shape_keys, f'key_blocks["{name_k}"].value')
        reimported[name_k] = np.array([fc.evaluate(f) for f in frames])
        expected = original.get(name_k, np.full(len(frames), rest[name_k]))
        assert np.abs(reimported[name_k] - expected).max() <= 1e-3, name_k
        keys_at = fcurve_values(back, name_k)[0]
        if name_k in keyed:  # keys over the whole line, not a flattened curve
            assert keys_at[0] <= first and keys_at[-1] >= end - 1 and len(keys_at) >= end - first
    # The lips close on each /p b m/ in the re-imported animation.
    line = (frames >= first) & (frames <= end)
    _assert_lips_close((frames[line] - first) / FPS, {k: v[line] for k, v in reimported.items()}, name, FPS)
