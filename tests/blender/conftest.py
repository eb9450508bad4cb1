"""Headless tests of the Blender extension with the ``bpy`` module.

The extension is built (``tools/build_extension.py``) and installed from
its zip into a throwaway user folder, the way users install it, because
packaging and registration errors only show up that way.  Set
``EMOTIVE_LIPSYNC_ZIP`` to test an already built zip.
"""

from __future__ import annotations

import glob
import os
import subprocess
import sys
import tempfile

# Blender reads this when bpy is first imported: keep the user's own
# Blender configuration out of the tests.
_USER = tempfile.mkdtemp(prefix="lipsync-user-")
os.environ["BLENDER_USER_RESOURCES"] = _USER

import bpy  # noqa: E402
import pytest  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
FIXTURES = os.path.join(ROOT, "tests", "fixtures")
SAMPLE = os.path.join(ROOT, "sample_rigs", "speech", "hello.wav")
MODULE = "bl_ext.user_default.emotive_lipsync"

sys.path.insert(0, os.path.join(ROOT, "sample_rigs"))
import build_rigs  # noqa: E402


def _build_zip() -> str:
    given = os.environ.get("EMOTIVE_LIPSYNC_ZIP")
    if given:
        return given
    out = tempfile.mkdtemp(prefix="lipsync-dist-")
    subprocess.run([sys.executable, os.path.join(ROOT, "tools", "build_extension.py"), "--platform", "linux-x64",
                    "--output-dir", out], check=True, stdout=subprocess.DEVNULL)
    return glob.glob(os.path.join(out, "*.zip"))[0]


@pytest.fixture(scope="session")
def extension():
    """The installed, enabled extension's Python package."""
    zip_path = _build_zip()
    result = bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default",
                                                      enable_on_install=True)
    assert result == {"FINISHED"}
    assert MODULE in bpy.context.preferences.addons
    import importlib

    return importlib.import_module(MODULE)


@pytest.fixture
def scene(extension):
    """An empty file with the two sample characters, at 30 fps."""
    bpy.ops.wm.read_homefile(use_empty=True)
    build_rigs.build_scene_objects()
    sc = bpy.context.scene
    sc.render.fps, sc.render.fps_base = 30, 1.0
    return sc


def add_strip(scene, name, path, frame=1, channel=1):
    from importlib import import_module

    compat = import_module(MODULE + ".blender.compat")
    return compat.new_sound_strip(scene, name, path, channel, frame)


def fcurve_values(obj, shape_key):
    """(frames, values) of a shape key's F-curve, or None."""
    import numpy as np
    from importlib import import_module

    compat = import_module(MODULE + ".blender.compat")
    key = obj.data.shape_keys
    fc = compat.find_fcurve(key, f'key_blocks["{shape_key}"].value')
    if fc is None:
        return None
    co = np.empty(2 * len(fc.keyframe_points))
    fc.keyframe_points.foreach_get("co", co)
    return co[0::2], co[1::2]


def keyed_shape_keys(obj):
    from importlib import import_module

    compat = import_module(MODULE + ".blender.compat")
    out = set()
    for fc in compat.fcurves(obj.data.shape_keys):
        if fc.data_path.startswith('key_blocks["'):
            out.add(fc.data_path.split('"')[1])
    return out
