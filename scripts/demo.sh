#!/usr/bin/env bash
# Runs the main job on the bundled demo project. Sets itself up on a fresh machine.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
rm -rf out/demo
.venv/bin/spinemesh upgrade examples/demo --out out/demo --report out/demo/report.json --images out/demo/editor-images
echo "Upgraded project in out/demo (report: out/demo/report.json)."
