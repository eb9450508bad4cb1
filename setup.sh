#!/usr/bin/env bash
# Build the project's environment in .venv/ and lip-sync the shipped sample.
#   ./setup.sh            environment + sample run (writes out/hello.json, out/hello.csv)
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
.venv/bin/python -m addon analyze sample_rigs/speech/hello.wav --transcript sample_rigs/speech/hello.txt \
  --emotion happy --fps 24 --json out/hello.json --csv out/hello.csv
echo "wrote out/hello.json and out/hello.csv"
