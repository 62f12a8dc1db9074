"""The ``spinemesh`` command line.

Each command lives in its own module of this package and registers itself on :data:`app`;
this module only imports them. Errors of the :class:`~spinemesh.errors.SpineMeshError`
family are printed as one line, never as a traceback.
"""

from __future__ import annotations

import sys

from ._app import app, console, err_console  # noqa: F401
from . import info  # noqa: F401,E402
from . import convert  # noqa: F401,E402
from . import segment  # noqa: F401,E402
from . import dataset  # noqa: F401,E402
from . import mesh  # noqa: F401,E402
from . import diff  # noqa: F401,E402
from . import upgrade  # noqa: F401,E402


def main() -> None:
    """Console-script entry point."""
    from ..errors import SpineMeshError

    try:
        app()
    except SpineMeshError as e:
        err_console.print(f"[bold red]error:[/] {e}")
        sys.exit(2)
