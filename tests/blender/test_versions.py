"""What differs between the Blenders the extension supports (4.2 LTS to
5.2 LTS, Python 3.11 and 3.13): the wheels the zip carries and the one
Blender installs, audio decoding with and without Audaspace, and the check
that the extension uses no deprecated API."""

from __future__ import annotations

import importlib.machinery
import os
import re
import sys
import tomllib
import warnings
import zipfile
from importlib import import_module

import bpy
import numpy as np

from conftest import _USER, EXTENSION_DIR, FIXTURES, MODULE, extension_deprecations

PACKAGES = {"praat_parselmouth": "0.4.7", "pocketsphinx": "5.1.1"}
#: Wheels for any Python 3 (``py3``): eSpeak NG's library and data, and Japanese readings.
ANY_PYTHON = {"espeakng_loader": "0.2.4", "pykakasi": "2.3.0", "jaconv": "0.5.0", "deprecated": "1.3.1",
              "wrapt": "2.5.2"}
PYTHONS = {"cp311", "cp313"}
THIS_PYTHON = f"cp{sys.version_info.major}{sys.version_info.minor}"


def _zip_wheels(zip_path):
    """The wheels the zip's manifest lists, as file names, and the names of
    the zip's members."""
    with zipfile.ZipFile(zip_path) as z:
        manifest = tomllib.loads(z.read("blender_manifest.toml").decode("utf-8"))
        members = set(z.namelist())
    return [os.path.basename(w) for w in manifest["wheels"]], members


def _tags(wheel):
    """(name, version, Python tag); any pure-Python tag (``py3``, ``py2.py3``) is ``py3``."""
    parts = wheel[:-len(".whl")].split("-")
    return parts[0], parts[1], "py3" if parts[-3].startswith("py") else parts[-3]


def test_zip_carries_both_pythons_wheels(extension_zip):
    wheels, members = _zip_wheels(extension_zip)
    for w in wheels:
        assert f"wheels/{w}" in members, f"{w} is listed but not in the zip"
    found = {(name, version, py) for name, version, py in map(_tags, wheels)}
    assert found == ({(name, version, py) for name, version in PACKAGES.items() for py in PYTHONS}
                     | {(name, version, "py3") for name, version in ANY_PYTHON.items()})
    assert len(wheels) == len(found)  # one wheel per package and Python on this platform


def test_this_blender_installs_only_its_pythons_wheels(extension_zip):
    """Blender's own installer code, run on the zip's wheel list: this
    Blender's filter and de-duplication keep this Python's wheels, and the
    first 4.2 releases' rule (platform filter only, then of two wheels of one
    package and version the file name sorting last wins) keeps the cp311
    ones."""
    from _bpy_internal.extensions.wheel_manager import wheel_list_deduplicate_as_skip_set

    def installed(wheels):
        skipped = wheel_list_deduplicate_as_skip_set([("emotive_lipsync", wheels)])
        return [w for w in wheels if w not in skipped]

    wheels, _members = _zip_wheels(extension_zip)
    assert {_tags(w)[2] for w in installed(wheels)} == {"cp311", "py3"}
    ops = import_module("bl_pkg.bl_extension_ops")
    this_filter = getattr(ops, "_extensions_wheel_filter_for_this_system", None) \
        or ops._extensions_wheel_filter_for_platform  # 4.2.0
    kept = installed(this_filter(wheels))
    assert {_tags(w)[2] for w in kept} == {THIS_PYTHON, "py3"}
    assert sorted(_tags(w)[0] for w in kept) == sorted({**PACKAGES, **ANY_PYTHON})


def test_installed_wheels_are_this_pythons(extension):
    site = os.path.join(_USER, "extensions", ".local", "lib", f"python{sys.version_info.major}."
                        f"{sys.version_info.minor}", "site-packages")
    names = os.listdir(site)
    assert {n for n in names if n.endswith(".dist-info")} == {f"{p}-{v}.dist-info"
                                                               for p, v in {**PACKAGES, **ANY_PYTHON}.items()}
    compiled = [os.path.join(root, f) for root, _dirs, files in os.walk(site) for f in files
                if re.search(r"\.cpython-\d+-[^/]*\.so$", f)]
    assert len(compiled) >= 2  # parselmouth's module and pocketsphinx's
    suffix = importlib.machinery.EXTENSION_SUFFIXES[0]  # ".cpython-311-x86_64-linux-gnu.so"
    assert all(f.endswith(suffix) for f in compiled), compiled
    for name in ("parselmouth", "pocketsphinx", "espeakng_loader", "pykakasi"):
        assert import_module(name)  # from the extension's wheels, or the dev environment's own


def test_audio_decodes_with_or_without_audaspace(extension):
    """Blender's decoder where it has one, else the engine's reader, and
    the two give the same samples."""
    compat = import_module(MODULE + ".blender.compat")
    engine_audio = import_module(MODULE + ".engine.audio")
    path = os.path.join(FIXTURES, "bob_map.wav")
    try:
        import aud  # noqa: F401
        has_aud = True
    except ImportError:
        has_aud = False
    assert compat.AUDASPACE == has_aud == bool(bpy.app.build_options.audaspace)
    decoded = compat.decode_file(path)
    reference = engine_audio.load(path)
    assert decoded.rate == reference.rate == engine_audio.MODEL_RATE
    assert len(decoded.samples) == len(reference.samples)
    assert np.abs(decoded.samples - reference.samples).max() < 1e-3


def test_deprecation_check_sees_the_extensions_files(extension):
    """The check every test runs (``conftest.no_deprecated_api``) looks where
    the extension is installed, and only there."""
    assert os.path.abspath(import_module(MODULE + ".blender.compat").__file__).startswith(EXTENSION_DIR + os.sep)
    with warnings.catch_warnings(record=True) as records:
        warnings.simplefilter("always")
        warnings.warn_explicit("'SoundStrip.frame_start' is expected to be removed in Blender 6.0",
                               DeprecationWarning, os.path.join(EXTENSION_DIR, "blender", "sources.py"), 7)
        warnings.warn_explicit("old API in a test", DeprecationWarning, __file__, 1)
        warnings.warn_explicit("not a deprecation", UserWarning, os.path.join(EXTENSION_DIR, "x.py"), 1)
    assert extension_deprecations(records) == [
        os.path.join("blender", "sources.py") + ":7: 'SoundStrip.frame_start' is expected to be removed in Blender 6.0"]


def test_strip_timing_without_deprecated_names(scene):
    """A trimmed strip's visible frames and content start, through the shim
    (the 5.1 names where Blender has them: the check above would fail this
    test otherwise)."""
    from conftest import add_strip

    compat = import_module(MODULE + ".blender.compat")
    strip = add_strip(scene, "line", os.path.join(FIXTURES, "bob_map.wav"), frame=10)
    first, end = compat.strip_frames(strip)
    assert (first, compat.strip_content_start(strip)) == (10, 10)
    assert end - first == 50  # 1.669 s at 30 fps
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # the test sets the trim by either name
        if compat.STRIP_HANDLES:
            strip.left_handle_offset = 6
        else:
            strip.frame_offset_start = 6
    assert compat.strip_frames(strip) == (16, end)
    assert compat.strip_content_start(strip) == 10
    assert compat.strip_sound_offset(strip) == 0.0
    clip = import_module(MODULE + ".blender.sources").strip_clip(scene, strip)
    assert clip.first_frame == 16
    assert abs(clip.audio.duration - 44 / 30) < 0.01
