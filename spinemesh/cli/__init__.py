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
from . import weights  # noqa: F401,E402


def main() -> None:
    """Console-script entry point.

    A :class:`~spinemesh.errors.SpineMeshError` is printed as one line (never wrapped, even
    when stderr is not a terminal, so that scripts can grep it) and exits with 2. SIGTERM and
    SIGHUP end the run like Ctrl-C does, so temporary files are removed on the way out.
    """
    from ..errors import SpineMeshError
    from ..processes import exit_on_terminate

    exit_on_terminate()
    try:
        app()
    except SpineMeshError as e:
        from rich.markup import escape

        err_console.print(f"[bold red]error:[/] {escape(str(e))}", highlight=False, soft_wrap=True)
        sys.exit(2)
