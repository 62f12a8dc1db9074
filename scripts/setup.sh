#!/usr/bin/env bash
# Creates .venv and installs spinemesh with its extras. Safe to run again: it only
# installs what is missing.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ ! -x .venv/bin/python ]; then
    python3 -m venv .venv
    .venv/bin/python -m pip install -q --upgrade pip
fi
.venv/bin/python -m pip install -q -e ".[train,dev]"

# Headless Chromium for the HTML report test of `spinemesh diff` (skipped when absent).
if [ "$(id -u)" = 0 ]; then
    command -v chromium >/dev/null || (apt-get update && apt-get install -y chromium) || true
fi
