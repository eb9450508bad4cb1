#!/usr/bin/env bash
# Build the project's environment in .venv/ and run the sample job.
#   ./setup.sh            environment, then the sample: two rigs lip-synced
#                         headless -> out/sample.blend, out/sample_contact_sheet.png,
#                         and the engine's own output -> out/hello.json, out/hello.csv
#   ./setup.sh --no-run   environment only
set -euo pipefail
cd "$(dirname "$0")"
PY=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  "$PY" -m venv .venv
  .venv/bin/python -m pip install -q --upgrade pip
fi
.venv/bin/python -m pip install -q -r requirements.txt
[ "${1:-}" = "--no-run" ] && exit 0
mkdir -p out
.venv/bin/python sample_rigs/demo.py out 2>&1 | grep -v -e "^EGL Error" -e "render  *| Saved"
.venv/bin/python -m addon analyze sample_rigs/speech/hello.wav --transcript sample_rigs/speech/hello.txt \
  --emotion happy --fps 24 --json out/hello.json --csv out/hello.csv
echo "wrote out/hello.json and out/hello.csv"
