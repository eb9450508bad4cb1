"""Headless tests of the Blender extension with the ``bpy`` module.

The extension is built (``tools/build_extension.py``) and installed from
its zip into a throwaway user folder, the way users install it, because
packaging and registration errors only show up that way.  Set
``EMOTIVE_LIPSYNC_ZIP`` to test an already built zip.

The same tests run on every Blender the extension supports (``./test.sh``
runs 4.2, 4.5, 5.0, 5.2 and 5.3).  Two things here depend on the Blender:

* A test fails when the extension's own code used an API Blender has
  deprecated (a ``DeprecationWarning`` from a file of the installed
  extension): the version shim must use the current names.
* PyPI's ``bpy`` 4.2 is built without Audaspace and cannot add sound
  strips; :func:`add_strip` then pastes a strip read from a .blend instead
  (see ``sample_rigs/sound_strips.py``), and the tests that need the ``aud``
  module themselves are skipped there (:data:`NEEDS_AUD`).
* PyPI's ``bpy`` 4.2 and 4.3 crash (segmentation fault) while Python shuts
  down once any add-on class with a Python method was registered (an
  operator, a property group with a method; even after unregistering it);
  4.4 fixed it.  There the test process ends right after pytest's report,
  with pytest's exit status (:func:`pytest_unconfigure`).
"""

from __future__ import annotations

import atexit
import glob
import os
import shutil
import subprocess
import sys
import tempfile
import warnings

# Blender reads these when bpy is first imported: keep the user's own
# Blender configuration out of the tests, and give this run a temporary
# folder of its own (Blender keeps its sequencer clipboard there, and test
# runs may go on at the same time).
_USER = tempfile.mkdtemp(prefix="lipsync-user-")
_TMP = tempfile.mkdtemp(prefix="lipsync-tmp-")
os.environ["BLENDER_USER_RESOURCES"] = _USER
os.environ["TMPDIR"] = _TMP
atexit.register(shutil.rmtree, _TMP, True)
atexit.register(shutil.rmtree, _USER, True)

import bpy
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
FIXTURES = os.path.join(ROOT, "tests", "fixtures")
SAMPLE = os.path.join(ROOT, "sample_rigs", "speech", "hello.wav")
MODULE = "bl_ext.user_default.emotive_lipsync"

sys.path.insert(0, os.path.join(ROOT, "sample_rigs"))
import build_rigs
import sound_strips


#: Tests that use Blender's ``aud`` module themselves, skipped on a ``bpy``
#: built without Audaspace (the extension itself decodes without it).
NEEDS_AUD = {
    "test_audio_file_in_other_formats_and_packed_sound":
        "writes its FLAC and OGG files with Blender's aud module",
}


def pytest_collection_modifyitems(config, items):
    if bpy.app.build_options.audaspace:
        return
    for item in items:
        why = NEEDS_AUD.get(item.originalname)
        if why:
            item.add_marker(pytest.mark.skip(
                reason=f"this bpy {bpy.app.version_string} is built without Audaspace (no aud module); the test {why}"))


#: This bpy crashes at interpreter shutdown after an add-on was registered.
CRASHES_AT_EXIT = not bpy.app.binary_path and bpy.app.version < (4, 4, 0)
_exit_status = 0


def pytest_sessionfinish(session, exitstatus):
    global _exit_status
    _exit_status = int(exitstatus)


@pytest.hookimpl(trylast=True)
def pytest_unconfigure(config):
    if CRASHES_AT_EXIT:
        sys.stdout.flush()
        sys.stderr.flush()
        shutil.rmtree(_TMP, True)
        shutil.rmtree(_USER, True)
        os._exit(_exit_status)


@pytest.fixture(scope="session")
def extension_zip():
    """The built extension zip for this machine (linux-x64)."""
    given = os.environ.get("EMOTIVE_LIPSYNC_ZIP")
    if given:
        return given
    out = tempfile.mkdtemp(prefix="lipsync-dist-", dir=_TMP)
    subprocess.run([sys.executable, os.path.join(ROOT, "tools", "build_extension.py"), "--platform", "linux-x64",
                    "--output-dir", out], check=True, stdout=subprocess.DEVNULL)
    return glob.glob(os.path.join(out, "*.zip"))[0]


@pytest.fixture(scope="session")
def extension(extension_zip):
    """The installed, enabled extension's Python package."""
    result = bpy.ops.extensions.package_install_files(filepath=extension_zip, repo="user_default",
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


@pytest.fixture
def empty_scene(extension):
    """An empty file at 30 fps."""
    bpy.ops.wm.read_homefile(use_empty=True)
    sc = bpy.context.scene
    sc.render.fps, sc.render.fps_base = 30, 1.0
    return sc


#: Where the installed extension's own files are (not its bundled wheels).
EXTENSION_DIR = os.path.join(_USER, "extensions", "user_default", "emotive_lipsync")


def extension_deprecations(records) -> list[str]:
    """The deprecation warnings among ``records`` raised by the extension's
    own code, as ``file:line: message``."""
    own = os.path.join(EXTENSION_DIR, "")
    return [f"{os.path.relpath(w.filename, EXTENSION_DIR)}:{w.lineno}: {w.message}" for w in records
            if issubclass(w.category, DeprecationWarning) and os.path.abspath(w.filename).startswith(own)]


@pytest.fixture(autouse=True)
def no_deprecated_api():
    """Fail a test in which the extension used an API its Blender deprecated
    (5.1 renamed strip timing, for example).  Other warnings are passed on
    to pytest's summary."""
    with warnings.catch_warnings(record=True) as records:
        warnings.simplefilter("always")
        yield
    for w in records:
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    found = extension_deprecations(records)
    if found:
        pytest.fail(f"the extension used deprecated Blender API on {bpy.app.version_string}:\n  "
                    + "\n  ".join(sorted(set(found))), pytrace=False)


def add_strip(scene, name, path, frame=1, channel=1):
    """A sound strip of ``path`` on ``channel``, its sound starting at
    ``frame`` (pasted from ``strip_template.blend`` on a ``bpy`` without
    Audaspace: see ``sample_rigs/sound_strips.py``)."""
    from importlib import import_module

    return sound_strips.add(import_module(MODULE + ".blender.compat"), scene, name, path, frame, channel)


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
