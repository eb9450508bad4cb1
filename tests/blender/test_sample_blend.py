"""``out/sample.blend`` (``sample_rigs/demo.py --blend-only``) opens in the
Blender that saved it, with its two heads keyed and their sound strips; and
one saved by Blender 4.2, the oldest supported, opens in this Blender.

A .blend opens in the Blender that saved it and in later ones only (a file
saved by 5.0 has a header 4.2 cannot read), so ``./setup.sh`` saves the
sample with 4.2 when ``.venv-bpy42`` exists.  The demo runs in a process of
its own, the add-on from the checkout, the engine's compiled dependencies
(parselmouth, pocketsphinx) taken from where this process imports them (on
PyPI's 4.2 that is the installed extension's wheels)."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from importlib import import_module

import bpy
import numpy as np
import pytest

from conftest import MODULE, ROOT

DEMO = os.path.join(ROOT, "sample_rigs", "demo.py")
BPY42 = os.path.join(ROOT, ".venv-bpy42", "bin", "python")


def _engine_deps(folder) -> str:
    """A folder holding only parselmouth and pocketsphinx, as this process imports them."""
    import parselmouth
    import pocketsphinx

    os.makedirs(folder)
    os.symlink(parselmouth.__file__, os.path.join(folder, os.path.basename(parselmouth.__file__)))
    os.symlink(os.path.dirname(pocketsphinx.__file__), os.path.join(folder, "pocketsphinx"))
    return folder


def _write_sample(python: str, out_dir, deps: str) -> str:
    env = dict(os.environ, PYTHONPATH=deps, BLENDER_USER_RESOURCES=tempfile.mkdtemp(dir=out_dir))
    done = subprocess.run([python, DEMO, str(out_dir), "--blend-only"], env=env, capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    return os.path.join(out_dir, "sample.blend")


def _check_opens_keyed_with_strips(path):
    compat = import_module(MODULE + ".blender.compat")
    assert bpy.ops.wm.open_mainfile(filepath=path) == {"FINISHED"}
    scene = bpy.context.scene
    strips = {s.name: s for s in compat.sound_strips(scene)}
    assert set(strips) == {"Human_hello", "HumanRPM_hello"}
    for s in strips.values():
        assert os.path.samefile(bpy.path.abspath(s.sound.filepath), os.path.join(ROOT, "sample_rigs", "speech",
                                                                                     "hello.wav"))
        assert s.frame_final_start == 1 and 150 < s.frame_final_end < 230       # the line lasts about 6 s at 30 fps
    for name, shape in (("Human", "jawOpen"), ("HumanRPM", "viseme_PP")):
        key = bpy.data.objects[name].data.shape_keys
        curves = {fc.data_path.split('"')[1]: fc for fc in compat.fcurves(key)}
        assert shape in curves and len(curves) >= 10, sorted(curves)
        values = np.array([curves[shape].evaluate(f) for f in range(1, 191)])
        assert values.max() > 0.3 and values.min() < 0.05                  # it moves, and comes back


def test_the_sample_saved_by_this_blender_opens_in_it(extension, tmp_path):
    path = _write_sample(sys.executable, tmp_path, _engine_deps(str(tmp_path / "deps")))
    with open(path, "rb") as fh:
        head = fh.read(17)
    major, minor = bpy.app.version[:2]
    if (major, minor) < (5, 0):
        assert head[:12] == f"BLENDER-v{major}{minor:02d}".encode()            # the header every Blender reads
    _check_opens_keyed_with_strips(path)


@pytest.mark.skipif(not os.path.isfile(BPY42) or sys.version_info[:2] != (3, 11) or bpy.app.version < (4, 5, 0),
                    reason="needs .venv-bpy42 (./setup.sh --test-envs) and a later Blender on Python 3.11")
def test_the_sample_saved_by_blender_4_2_opens_in_this_later_blender(extension, tmp_path):
    path = _write_sample(BPY42, tmp_path, _engine_deps(str(tmp_path / "deps")))
    with open(path, "rb") as fh:
        assert fh.read(12) == b"BLENDER-v402"
    _check_opens_keyed_with_strips(path)
