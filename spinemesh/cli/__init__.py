"""The ``spinemesh`` command line.

Each command lives in its own module of this package and registers itself on the typer
application, ``app``; it is built on first use (``from spinemesh.cli import app`` works as
before), so that the console script can run a plain ``spinemesh convert SOURCE TARGET``
without importing typer (:mod:`.convert_files`). Errors of the
:class:`~spinemesh.errors.SpineMeshError` family are printed as one line, never as a traceback.
"""

from __future__ import annotations

import sys

#: The modules that register the commands, in the order of `spinemesh --help`: a new command's
#: module goes here.
_COMMAND_MODULES = ("info", "convert", "segment", "dataset", "mesh", "diff", "upgrade", "pack", "weights", "pose")


def _load_app():
    """The typer application with every command registered (imports typer and the command modules)."""
    from importlib import import_module

    from ._app import app

    for name in _COMMAND_MODULES:
        import_module(f"{__name__}.{name}")
    return app


def __getattr__(name: str):
    # PEP 562: `app`, `console` and `err_console` are made on first access, not at import.
    if name == "app":
        return _load_app()
    if name in ("console", "err_console"):
        from . import _app

        return getattr(_app, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _standard_streams() -> None:
    """Make the standard streams safe to write names to, whatever the environment.

    Standard output takes any name: where its encoding cannot write a character
    (``PYTHONIOENCODING=ascii``, a Windows console's code page, a latin-1 locale), it is written
    as a Python escape (``\\xe9``), as standard error already writes it; a project named
    ``héros`` ended every command's table in a UnicodeEncodeError traceback. (``pose`` writes
    its JSON as UTF-8 bytes, whatever the encoding.)
    """
    stdout = sys.stdout
    if stdout is not None and hasattr(stdout, "reconfigure"):
        stdout.reconfigure(errors="backslashreplace")


def _refusal(error: OSError):
    """What the system refused, as a :class:`~spinemesh.errors.SpineMeshError` naming the file.

    A relative path given from a folder removed under the shell (a build step's scratch folder
    cleaned while the command starts) cannot be made absolute: Python raises a bare "No such
    file or directory" naming nothing; it names the folder that is gone (the shell's ``PWD``).
    """
    import errno
    import os

    from ..errors import SpineMeshError

    if error.filename is None and error.errno == errno.ENOENT:
        try:
            os.getcwd()
        except OSError:
            return SpineMeshError("the current folder no longer exists, so relative paths cannot be found; "
                                  "run from a folder that exists or give absolute paths",
                                  os.environ.get("PWD") or None)
    return SpineMeshError(error.strerror or str(error), error.filename)


def _file_name_encoding(encoding: str) -> bool:
    """Whether ``encoding`` is the one Python names files in (a UnicodeEncodeError in it: a name
    this system's file names cannot hold)."""
    import codecs

    try:
        return codecs.lookup(encoding).name == codecs.lookup(sys.getfilesystemencoding()).name
    except LookupError:
        return False


def main() -> None:
    """Console-script entry point.

    A :class:`~spinemesh.errors.SpineMeshError` is printed as one line (never wrapped, even
    when stderr is not a terminal, so that scripts can grep it) and exits with 2, as does an
    ``OPENCV_*`` environment variable OpenCV cannot parse (checked first). SIGTERM and
    SIGHUP end the run like Ctrl-C does, so temporary files are removed on the way out. A run
    that does not succeed leaves none of the folders it made empty behind.
    """
    try:
        _run_command()
    except BaseException as e:
        if not isinstance(e, SystemExit) or e.code not in (0, None):
            _remove_made_folders_left_empty()
        raise


def _remove_made_folders_left_empty() -> None:
    """:func:`~spinemesh.written_folder.remove_made_folders_left_empty`, where this process could have
    made a folder (the module making them was imported)."""
    if f"{__package__.rpartition('.')[0]}.files.atomic" in sys.modules:
        from ..written_folder import remove_made_folders_left_empty

        remove_made_folders_left_empty()


def _run_command() -> None:
    """The command line run: its errors said in one line each, its exit status set (:func:`main`)."""
    try:  # from the first import on: a Ctrl-C while the command is imported (~50 ms) ended in a traceback
        from ..processes import exit_on_terminate

        exit_on_terminate()
        from ..errors import OutputStopped, SpineMeshError

        _standard_streams()
        from ..opencv_environment import check_opencv_environment

        check_opencv_environment()  # a value OpenCV cannot parse aborts the process at its import
        args = sys.argv[1:]
        if args[:1] == ["convert"]:
            from .convert_files import run_plain_convert

            if run_plain_convert(args[1:]):
                return
        _load_app()()
    except KeyboardInterrupt:  # where typer does not catch it (start-up, the plain convert)
        sys.exit(130)  # what typer ends Ctrl-C with: 128 + SIGINT, nothing printed
    except SystemExit as e:
        from ..processes import interrupted

        # a signal came: whatever ended the command, the run was not a success
        if interrupted() and e.code in (0, None):
            sys.exit(128 + interrupted())
        raise
    except UnicodeEncodeError as e:
        if not _file_name_encoding(e.encoding):
            raise
        from ._app import console_text, err_console

        # Python's file names are UTF-8 in every UTF-8 locale and in the C locale; a locale of another
        # encoding (latin-1), or the C locale with UTF-8 mode turned off (PYTHONUTF8=0), cannot name a
        # file whose name a project gives in other letters: one line saying so, not a traceback
        err_console.print(f"[bold red]error:[/] {console_text(e.object)}: this name cannot be a file name here "
                          f"(file names are {sys.getfilesystemencoding()} in this locale); run with a UTF-8 "
                          "locale (LC_ALL=C.UTF-8) or PYTHONUTF8=1", highlight=False, soft_wrap=True)
        sys.exit(2)
    except MemoryError:
        # the last net for memory: each stage refuses what it cannot hold with its own line naming
        # the file; what got past them still ends in one line, every file written being whole
        from ._app import err_console

        err_console.print("[bold red]error:[/] not enough memory to finish: the files written so far are whole, "
                          "the others were not written (try fewer --jobs, or one project at a time)",
                          highlight=False, soft_wrap=True)
        sys.exit(2)
    except OutputStopped as e:  # a full disk, said once: every later write would be refused too
        from ._app import console_text, err_console

        err_console.print(f"[bold red]error:[/] {console_text(str(e))}", highlight=False, soft_wrap=True)
        sys.exit(3)
    except (SpineMeshError, OSError) as e:  # last: SpineMeshError is bound once the command is imported
        from ._app import console_text, err_console

        if isinstance(e, OSError):  # the last net: what the system refused, as one line naming the file
            e = _refusal(e)
        err_console.print(f"[bold red]error:[/] {console_text(str(e))}", highlight=False, soft_wrap=True)
        sys.exit(2)
