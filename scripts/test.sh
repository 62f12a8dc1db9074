#!/usr/bin/env bash
# Runs the test suite. Sets itself up on a fresh machine (scripts/setup.sh: .venv with
# spinemesh and the extras the tests use, Node/npm and Chromium). The official Spine
# runtime tool's npm packages are installed by the tests themselves, once per run, into a
# temporary copy of ../shared/tools/spine-runtime (tests/conftest.py, spine_runtime).
#
# Tests run on every CPU core this process may use (pytest-xdist): each test file stays on
# one worker, except the runtime proofs, whose cases spread over all of them (see
# tests/conftest.py). Extra arguments go to pytest (e.g. -n 0 to run in one process).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
workers=$(.venv/bin/python -c 'import os; print(len(os.sched_getaffinity(0)))')
exec .venv/bin/python -m pytest -n "$workers" --dist loadgroup --durations=15 "$@"
