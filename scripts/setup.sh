#!/usr/bin/env bash
# Creates .venv and installs spinemesh with every extra the tests use (training, plots,
# Dask cluster, the documentation site, test tools), then the system programs the tests drive: Node and npm for the
# official Spine runtime, Chromium for the diff page. Safe to run again: it only installs
# what is missing. Anything it cannot install stops it with the reason (no silent skips).
set -euo pipefail
cd "$(dirname "$0")/.."
if [ ! -x .venv/bin/python ]; then
    python3 -m venv .venv
    .venv/bin/python -m pip install -q --upgrade pip
fi
.venv/bin/python -m pip install -q -e ".[train,stats,cluster,docs,dev]"

missing=()
command -v node >/dev/null && command -v npm >/dev/null || missing+=(nodejs npm)
command -v chromium >/dev/null || command -v chromium-browser >/dev/null || missing+=(chromium)
if [ ${#missing[@]} -gt 0 ]; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        apt-get update -q
        apt-get install -y -q "${missing[@]}"
    elif [ "${CI:-}" = true ]; then
        echo "setup: ${missing[*]} missing and cannot be installed here (not root, or no apt-get)" >&2
        exit 1
    else
        echo "setup: install ${missing[*]} to run every test; the tests that drive them skip until then" >&2
    fi
fi
