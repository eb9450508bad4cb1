#!/usr/bin/env bash
# Run every test: the engine (plain Python), then the Blender extension,
# built and installed from its zip, headless on Blender 5.0 and on 4.5 LTS.
# The environments are built first if needed.
#   ./test.sh                 everything
#   ./test.sh --engine-only   the engine's tests only (no Blender)
set -euo pipefail
cd "$(dirname "$0")"
./setup.sh --no-run
# Software OpenGL messages from headless Blender are noise here.
quiet() { "$@" 2> >(grep -v "^EGL Error" >&2); }
if [ "${1:-}" = "--engine-only" ]; then
  exec .venv/bin/python -m pytest -q tests --ignore=tests/blender
fi
.venv/bin/python -m pytest -q tests --ignore=tests/blender
echo "--- Blender $(.venv/bin/python -c 'import importlib.metadata as m; print(m.version("bpy"))' 2>/dev/null)"
quiet .venv/bin/python -m pytest -q tests/blender
if [ ! -x .venv-bpy45/bin/python ]; then
  "${PYTHON:-python3}" -m venv .venv-bpy45
fi
.venv-bpy45/bin/python -m pip install -q -r requirements-bpy45.txt
echo "--- Blender $(.venv-bpy45/bin/python -c 'import importlib.metadata as m; print(m.version("bpy"))' 2>/dev/null)"
quiet .venv-bpy45/bin/python -m pytest -q tests/blender
