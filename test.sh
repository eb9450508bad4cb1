#!/usr/bin/env bash
# Run every check: the linter (ruff), the engine's tests (plain Python) once,
# then the Blender extension's, built and installed from its zip, headless on
# each Blender it supports:
# 4.2 LTS, 4.5 LTS, 5.0 (Python 3.11), 5.2 LTS and 5.3 (Python 3.13), each the bpy
# module from PyPI in its own environment.  The environments are built first
# if needed (./setup.sh --test-envs).  Each Blender's tests run even when an
# earlier one failed; the summary at the end gives the counts per Blender.
#   ./test.sh                 everything
#   ./test.sh --engine-only   the engine's tests only (no Blender)
# With LIPSYNC_SLOW_TESTS=1 the engine's tests also run the guide's long commands
# (./setup.sh, the build for four platforms, the longer benchmarks: tests/test_docs.py).
# Without a Python 3.13 the 5.2 and 5.3 tests cannot run: that is reported,
# and is a failure under CI (CI=true).
set -euo pipefail
cd "$(dirname "$0")"
if [ "${1:-}" = "--engine-only" ]; then
  ./setup.sh --no-run
  exec .venv/bin/python -m pytest -q tests --ignore=tests/blender
fi
./setup.sh --test-envs

summary=()
passed=0 failed=0 skipped=0 status=0

# run LABEL PYTHON PYTEST-ARGS...: one pytest run, its output shown as it
# goes (headless Blender's software OpenGL messages dropped), its closing line
# and time kept for the summary.
run() {
  local label=$1 py=$2 log start rc line n
  shift 2
  log=$(mktemp)
  start=$SECONDS
  echo
  echo "=== $label ==="
  set +e
  "$py" -m pytest -q "$@" 2> >(grep -v "^EGL Error" >&2) | tee "$log"
  rc=${PIPESTATUS[0]}
  set -e
  line=$(grep -E "^=* *[0-9]+ (passed|failed|skipped|error|errors|deselected)" "$log" | tail -n 1 | tr -d '=')
  rm -f "$log"
  summary+=("$label: ${line:-no test summary (pytest exit status $rc)} [$((SECONDS - start)) s]")
  for kind in passed failed skipped error errors; do
    n=$(grep -oE "[0-9]+ $kind\b" <<<"$line" | grep -oE "^[0-9]+" || true)
    case $kind in
      passed) passed=$((passed + ${n:-0})) ;;
      skipped) skipped=$((skipped + ${n:-0})) ;;
      *) failed=$((failed + ${n:-0})) ;;
    esac
  done
  if [ "$rc" -ne 0 ]; then status=1; fi
}

# blender VENV: the extension tests on the Blender in VENV.
blender() {
  local version
  version=$("$1/bin/python" -c 'import importlib.metadata as m, sys
print(m.version("bpy"), "(Python %d.%d.%d)" % sys.version_info[:3])')
  run "Blender $version: extension tests ($1)" "$1/bin/python" tests/blender
}

echo
echo "=== Lint (ruff, rules in pyproject.toml) ==="
if .venv/bin/ruff check addon tests bench tools sample_rigs; then
  summary+=("Lint (ruff): clean")
else
  summary+=("Lint (ruff): FAILED, see above")
  status=1
fi

run "Engine (Python $(.venv/bin/python -c 'import platform; print(platform.python_version())'))" \
  .venv/bin/python tests --ignore=tests/blender
blender .venv-bpy42
blender .venv-bpy45
blender .venv
for v in 52 53; do
  if [ -x .venv-bpy$v/bin/python ]; then
    blender .venv-bpy$v
  else
    summary+=("!!! Blender ${v:0:1}.${v:1}: NOT RUN, no Python 3.13 on this machine (see ./setup.sh's message above)")
    if [ "${CI:-}" = "true" ]; then status=1; fi
  fi
done

echo
echo "=== Summary ==="
printf '%s\n' "${summary[@]}"
echo "total: $passed passed, $failed failed, $skipped skipped"
exit $status
