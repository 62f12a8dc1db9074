"""Regenerate the bundled demo project in examples/demo (drawn by spinemesh.demo)."""

import shutil
import sys
from pathlib import Path

from spinemesh.demo import make_demo_project

target = Path(sys.argv[1] if len(sys.argv) > 1 else Path(__file__).resolve().parents[1] / "examples" / "demo")
shutil.rmtree(target, ignore_errors=True)
make_demo_project(target)
print(f"demo project written to {target}")
