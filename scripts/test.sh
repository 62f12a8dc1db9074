#!/usr/bin/env bash
# Runs the test suite. Sets itself up on a fresh machine: a virtual environment in .venv
# with spinemesh and its training and test extras, and the Node runtime tool's packages.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
exec .venv/bin/python -m pytest "$@"
