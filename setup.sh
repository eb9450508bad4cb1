#!/usr/bin/env bash
# Build the project's environment in .venv/ and run the sample job.
#   ./setup.sh               environment, then the sample: the human head (ARKit and
#                            Ready Player Me variants) lip-synced headless ->
#                            out/sample.blend, out/sample_contact_sheet.png,
#                            out/sample_emotions.png (the seven emotion presets), out/sample.mp4,
#                            and the engine's own output -> out/hello.json, out/hello.csv;
#                            with .venv-bpy42/ (--test-envs) sample.blend is saved by 4.2
#   ./setup.sh --no-run      environment only
#   ./setup.sh --test-envs   environment and the other Blenders the extension is
#                            tested on (./test.sh does this): .venv-bpy42/ (4.2 LTS),
#                            .venv-bpy45/ (4.5 LTS), Python 3.11; .venv-bpy52/ (5.2 LTS)
#                            and .venv-bpy53/ (5.3), Python 3.13
# .venv/ holds Blender 5.0 (bpy from PyPI) and needs Python 3.11, as do 4.2 and
# 4.5; 5.2 and 5.3 need Python 3.13.  Each is looked for as $PYTHON311/$PYTHON313,
# python3.11/python3.13 on the PATH, then pyenv's versions ($PYENV_ROOT, or
# ~/.pyenv); python3 is used for 3.11 if it is 3.11.
set -euo pipefail
cd "$(dirname "$0")"

# A working CPython X.Y (not a free-threaded build): the first found, newest
# pyenv version first.
find_python() {
  local want=$1 var=$2 c
  local pyenv_root=${PYENV_ROOT:-$HOME/.pyenv}
  for c in "${!var:-}" "python$want" python3 \
           $(ls -d "$pyenv_root/versions/$want".*/bin/"python$want" 2>/dev/null | sort -rV); do
    [ -n "$c" ] || continue
    if "$c" -c "import sys, sysconfig
sys.exit(sys.version_info[:2] != (${want%.*}, ${want#*.}) or bool(sysconfig.get_config_var('Py_GIL_DISABLED')))" \
         >/dev/null 2>&1; then
      command -v "$c"
      return 0
    fi
  done
  return 1
}

# venv DIR PYTHON REQUIREMENTS: create DIR with PYTHON if needed, then install.
venv() {
  if [ ! -x "$1/bin/python" ]; then
    "$2" -m venv "$1"
    "$1/bin/python" -m pip install -q --upgrade pip
  fi
  "$1/bin/python" -m pip install -q -r "$3"
}

if [ ! -x .venv/bin/python ]; then
  PY=$(find_python 3.11 PYTHON311) || {
    echo "setup: Python 3.11 is needed (Blender 4.2-5.0's Python) and none was found: install it" \
         "(pyenv install 3.11, or your system's python3.11 package), or set PYTHON311=/path/to/python3.11" >&2
    exit 1
  }
fi
venv .venv "${PY:-}" requirements.txt

if [ "${1:-}" = "--test-envs" ]; then
  venv .venv-bpy42 "$(.venv/bin/python -c 'import sys; print(sys._base_executable)')" requirements-bpy42.txt
  venv .venv-bpy45 "$(.venv/bin/python -c 'import sys; print(sys._base_executable)')" requirements-bpy45.txt
  if PY313=$(find_python 3.13 PYTHON313); then
    venv .venv-bpy52 "$PY313" requirements-bpy52.txt
    venv .venv-bpy53 "$PY313" requirements-bpy53.txt
  elif [ -x .venv-bpy52/bin/python ] && [ -x .venv-bpy53/bin/python ]; then
    venv .venv-bpy52 "" requirements-bpy52.txt
    venv .venv-bpy53 "" requirements-bpy53.txt
  else
    echo "setup: no Python 3.13 found, so Blender 5.2 and 5.3 cannot be tested: install it (pyenv install 3.13," \
         "or your system's python3.13 package), or set PYTHON313=/path/to/python3.13" >&2
  fi
  exit 0
fi
[ "${1:-}" = "--no-run" ] && exit 0
mkdir -p out
.venv/bin/python sample_rigs/demo.py out 2>&1 | grep -v -e "^EGL Error" -e "render  *| Saved"
if [ -x .venv-bpy42/bin/python ]; then
  # sample.blend saved again by Blender 4.2 opens in every supported Blender (saved by 5.0 it needs 4.5 or
  # later). PyPI's bpy 4.2 lacks the engine's parselmouth and pocketsphinx: their wheels go into
  # build/sample-bpy42, for this run only.
  [ -d build/sample-bpy42/pocketsphinx ] || .venv-bpy42/bin/python -m pip install -q --no-deps \
    --target build/sample-bpy42 praat-parselmouth==0.4.7 pocketsphinx==5.1.1
  PYTHONPATH=build/sample-bpy42 .venv-bpy42/bin/python sample_rigs/demo.py out --blend-only 2>&1 \
    | grep -v -e "^EGL Error" -e "copybuffer_vse"
fi
.venv/bin/python -m addon analyze sample_rigs/speech/hello.wav --transcript sample_rigs/speech/hello.txt \
  --emotion happy --fps 24 --json out/hello.json --csv out/hello.csv
echo "wrote out/hello.json and out/hello.csv"
