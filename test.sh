#!/usr/bin/env bash
# Run the test suite in the project's environment (built first if needed).
set -euo pipefail
cd "$(dirname "$0")"
./setup.sh --no-run
exec .venv/bin/python -m pytest -q tests "$@"
