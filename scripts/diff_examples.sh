#!/usr/bin/env bash
# Regenerates the README's "Generated meshes against the artists' meshes" table: every artist
# mesh of the official 4.2 examples (../shared/spine-examples/4.2), compared with our presets and
# the paper's three baselines. Writes report.md, report.json and index.html to build/diff-4.2/
# (or the folder given as $1) and prints the aggregate table.
#
#   scripts/diff_examples.sh                 # about 5-10 minutes on 2 CPU cores
#   scripts/diff_examples.sh /tmp/diff-4.2   # elsewhere
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-build/diff-4.2}"
exec .venv/bin/python -m spinemesh diff ../shared/spine-examples/4.2/*/ --out "$out"
