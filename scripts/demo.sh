#!/usr/bin/env bash
# Try spinemesh on the bundled demo project (examples/demo, drawn by scripts/make_demo_project.py).
#
# On a fresh machine it installs the product alone into .venv (`pip install .`: numpy, OpenCV,
# ONNX Runtime and the like; no PyTorch, no system packages, no browser), then upgrades the demo
# and writes a picture of what changed. It changes nothing outside this folder. Run again: reuses .venv.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ ! -x .venv/bin/spinemesh ]; then
    python3 -m venv .venv
    .venv/bin/python -m pip install -q .
fi
.venv/bin/spinemesh upgrade examples/demo --out out/demo --overwrite \
    --preview out/demo-preview --report out/demo/report.json
echo
echo "Upgraded project: out/demo (report: out/demo/report.json). Open this page to see what changed:"
echo "  file://$(pwd)/out/demo-preview/index.html"
echo "Run spinemesh yourself: .venv/bin/spinemesh --help   (or: source .venv/bin/activate; spinemesh --help)"
