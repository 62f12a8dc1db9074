"""Hostile round twelve, first part: the process a command runs as.

Round eleven attacked the environment a command is handed; this one attacks the process itself, as a
build system, a CI job or an impatient user treats it: Ctrl-C the moment it starts, SIGTERM and SIGHUP
in the middle of a run over workers, a umask or a disk that refuses the output, standard output
closed, a worker pool the system refuses a process. Every project is made here by our own code
(``twenty``: the demo with twenty skeletons); each case runs ``python -m spinemesh`` in a subprocess
and checks what docs/safety.md promises.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from test_hostile_round11b import _env, twenty  # noqa: F401 (a fixture)

REPO = Path(__file__).resolve().parents[1]


# --- Ctrl-C the moment a command starts -------------------------------------------------------------

#: Run the command line as ``python -m spinemesh`` does, after a finder that sends this process
#: SIGINT when the module named in ``argv[1]`` is first looked for: a Ctrl-C at that very moment
#: of the start-up, whatever the machine's speed.
_INTERRUPTED_AT_IMPORT = """
import os, runpy, signal, sys
AT = sys.argv[1]
class Interrupt:
    def find_spec(self, name, path=None, target=None):
        if name == AT:
            sys.meta_path.remove(self)
            os.kill(os.getpid(), signal.SIGINT)
        return None
sys.meta_path.insert(0, Interrupt())
sys.argv = ["spinemesh", *sys.argv[2:]]
runpy.run_module("spinemesh", run_name="__main__", alter_sys=True)
"""


@pytest.mark.parametrize("module", ["spinemesh.cli", "spinemesh.processes", "spinemesh.errors"])
def test_ctrl_c_while_the_command_is_imported_ends_quietly(tmp_path, twenty, module):  # noqa: F811
    """Ctrl-C in the first ~50 ms of a command, while its modules were imported (before the run's own
    handler was in place): a Python traceback of a dozen frames, exit 1 or killed by SIGINT. It ends
    as a Ctrl-C a moment later does: exit 130, nothing printed."""
    r = subprocess.run([sys.executable, "-c", _INTERRUPTED_AT_IMPORT, module, "info", str(twenty)], cwd=tmp_path,
                       env=_env(), capture_output=True, timeout=120, check=False)
    assert r.returncode == 130 and r.stderr == b"" and r.stdout == b"", (r.returncode, r.stderr.decode()[-2000:])
