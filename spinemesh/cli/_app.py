"""The shared typer application, its consoles, choices, checks and progress bar.

Start-up time matters for a command line: ``spinemesh --help`` or ``spinemesh convert``
should not pay for numpy, OpenCV, ONNX Runtime, matplotlib or PIL. So nothing here imports
more than typer: the rich consoles are made on first use, and each command imports what it
needs inside its own function. Help is click's plain layout (``rich_markup_mode=None``):
typer's rich help imports rich's Markdown renderer, which alone costs about 60 ms.
``benchmarks/bench_startup.py`` measures it.
"""

from __future__ import annotations

import errno
import math
import os
import sys
from enum import Enum
from typing import Annotated, Optional

import typer
from typer.core import TyperGroup

try:
    from typer._click.exceptions import NoArgsIsHelpError, UsageError  # typer 0.28 carries its own click
except ImportError:  # typer 0.26 and 0.27 use click itself
    from click.exceptions import NoArgsIsHelpError, UsageError

from .. import __version__


def usage_error_line(error: UsageError) -> str:
    """What a bad option or argument says, one line without the ``error:`` prefix.

    ``upgrade: No such option: --bogus (Possible options: --jobs, --out) (see 'spinemesh
    upgrade --help')``: the command, click's own message (the option or value it names, the
    choices), and where the help is; click prints the usage, a hint and a blank line before it.
    """
    ctx = error.ctx
    message = error.format_message().removesuffix(".")
    if ctx is None:
        return message
    names = []
    while ctx.parent is not None:  # the command (and group) names under the program's
        names.append(ctx.info_name or "")
        ctx = ctx.parent
    command = " ".join(reversed(names))
    return f"{command + ': ' if command else ''}{message} (see '{error.ctx.command_path} --help')"


class _OneLineUsageErrors(TyperGroup):
    """The application's group: every usage error of every command (an unknown option or
    command, a missing argument, a bad Enum choice or number, a callback's ``BadParameter``) is
    one ``error:`` line on stderr, exit status 2 as click's; ``spinemesh`` alone still prints
    the help. Parsing happens in ``make_context`` (the group's options, the command's name) and
    in ``invoke`` (the command's own options, then its body)."""

    def make_context(self, info_name, args, parent=None, **extra):
        try:
            return super().make_context(info_name, args, parent=parent, **extra)
        except UsageError as e:
            _refuse_usage(e)

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except UsageError as e:
            _refuse_usage(e)


def _refuse_usage(error: UsageError):
    """Print ``error`` as one line and end the run with its status (2); the help asked for by
    ``spinemesh`` without a command goes on as click prints it."""
    if isinstance(error, NoArgsIsHelpError):
        raise error
    err_console.print(f"[bold red]error:[/] {console_text(usage_error_line(error))}", highlight=False,
                      soft_wrap=True)
    raise typer.Exit(error.exit_code)


app = typer.Typer(
    cls=_OneLineUsageErrors,
    name="spinemesh",
    help="Automatic triangle meshes for Spine projects.\n\n"
         "Example: spinemesh upgrade project/ --out meshed/ --preview meshed-preview/",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,
    context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100},
)


class Preset(str, Enum):
    """Mesher presets (the keys of :data:`spinemesh.mesher.PRESETS`)."""

    default = "default"
    paper = "paper"


def refuse_default_preset_options(preset: Preset, given: dict[str, object]) -> None:
    """Refuse, before any work, the options that tune the default preset alone with ``--preset paper``.

    The paper preset meshes as the paper's section 3, to the letter: it reads no density, vertex
    budget or saving, so a run given them made the same meshes as without them and said nothing
    (``--max-vertices 60`` gave meshes of 94 vertices).

    Parameters
    ----------
    preset : Preset
        The ``--preset`` given.
    given : dict
        Option name (``--density``) to its value, None where it was not given.
    """
    from ..errors import SpineMeshError

    named = [name for name, value in given.items() if value is not None]
    if preset is Preset.paper and named:
        raise SpineMeshError(f"{' and '.join(named)} {'tunes' if len(named) == 1 else 'tune'} the default preset "
                             "only: --preset paper meshes as the paper's section 3, to the letter; leave "
                             f"{'it' if len(named) == 1 else 'them'} out, or leave out --preset paper")


class MaskSource(str, Enum):
    """Where the foreground comes from (:data:`spinemesh.segment.MASK_MODES`)."""

    auto = "auto"
    alpha = "alpha"
    model = "model"


#: The narrowest the consoles draw, in columns. ``COLUMNS=0`` (what some build servers set where
#: there is no terminal) made rich draw at width 0: nothing came out, not the table, not even an
#: error line; below about 40 columns a table shows no number. A narrower width is taken as this
#: one (a terminal that narrow wraps the lines), and 0 as no width given (rich's 80, as it takes
#: a terminal that reports 0).
NARROWEST_CONSOLE = 40


class _StandardStream:
    """The standard stream a console writes to, looked up at each write as rich does (a test's
    capture, rich's live display replace it), through which what the system refuses is told
    apart by stream.

    Standard error holds only words about the run (bars, warnings, the error line): a log that
    cannot take them (a full disk behind ``2> build.log``, a closed pipe) ended the run at the
    next bar (exit status 1, the files after it never written). Writes there that fail are
    dropped and the run goes on; its exit status still says how it ended. Standard output holds
    what a command was asked for (its table, ``info``): a write there that fails ends the run in
    one line naming standard output, and a reader that closed the pipe (``| head``) ends it as
    the command line does (``BrokenPipeError``, exit status 1).
    """

    def __init__(self, stderr: bool):
        self._stderr = stderr

    @property
    def stream(self):
        from rich._null_file import NULL_FILE

        stream = sys.stderr if self._stderr else sys.stdout
        stream = getattr(stream, "rich_proxied_file", stream)  # rich's live display holds the real one
        return NULL_FILE if stream is None else stream

    def _refused(self, error: OSError) -> None:
        if self._stderr:
            return
        if error.errno == errno.EPIPE:
            raise error
        raise OSError(error.errno, f"cannot write: {error.strerror or error}", "standard output") from None

    def write(self, text: str) -> int:
        if not self._stderr and sys.stdout is None:
            _say_standard_output_closed()
        try:
            return self.stream.write(text)
        except OSError as e:
            self._refused(e)
            return len(text)

    def flush(self) -> None:
        try:
            self.stream.flush()
        except OSError as e:
            self._refused(e)

    def __getattr__(self, name):
        return getattr(self.stream, name)


#: Whether the run said that standard output is closed (once a run).
_said_closed = []


def _say_standard_output_closed() -> None:
    """One warning, at a command's first write to a closed standard output (``>&-``, a daemon):
    its table is dropped, and its files (what it makes) are whole. A command whose standard
    output is all it makes (``info``, ``pose``) refuses it before any work instead
    (``files.guard.check_outputs``)."""
    if _said_closed:
        return
    _said_closed.append(True)
    from ..files.guard import STANDARD_OUTPUT_CLOSED

    err_console.print(f"[yellow]warning:[/] {STANDARD_OUTPUT_CLOSED}", highlight=False, soft_wrap=True)


def _is_a_tty(stream) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError, OSError):
        return False


class _LazyConsole:
    """A rich ``Console`` made on first use, so that importing the CLI does not import rich."""

    def __init__(self, stderr: bool):
        self._stderr = stderr
        self._console = None

    @property
    def real(self):
        """The rich ``Console`` itself (for rich objects that take a ``console=``)."""
        if self._console is None:
            from rich.console import Console

            # Text is never wrapped by us (tables still fit the width): one error stays one line in
            # a log or a pipe, and a path in a message stays whole, to copy and paste.
            self._console = Console(file=_StandardStream(self._stderr), stderr=self._stderr, soft_wrap=True)
            if self._console.width <= 0:
                self._console.width = 80
            elif self._console.width < NARROWEST_CONSOLE:
                self._console.width = NARROWEST_CONSOLE
            if self._console.is_interactive and "TTY_INTERACTIVE" not in os.environ and not _is_a_tty(self._console.file):
                # FORCE_COLOR (which CI logs are given for colours) made rich take a log for a terminal
                # and redraw the bars into it ten times a second (45 KB in 10 s of `upgrade`): a
                # stream that is no terminal gets the colours, and each bar once, when it ends
                self._console.is_interactive = False
        return self._console

    def __getattr__(self, name):
        return getattr(self.real, name)


console = _LazyConsole(stderr=False)
err_console = _LazyConsole(stderr=True)


def progress_bar(label: str, transient: bool = False, phases: bool = False):
    """A rich progress bar on stderr: a spinner, label, bar, done/total, elapsed, time remaining,
    current item.

    With ``phases``, one bar per task, each named by its description (a phase: ``read``,
    ``mesh``, ...) instead of ``label``, and ended by its ``project`` field (the project a
    library run is on).
    """
    from rich.progress import (
        BarColumn, MofNCompleteColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn,
        TimeRemainingColumn,
    )
    from rich.table import Column
    from rich.text import Text

    class Bars(Progress):
        def stop(self) -> None:
            # rich ends a display on a console that is no terminal (a pipe, a log) with a blank
            # line; a transient one drew nothing there, so that line would only stand before
            # what comes next (an error line)
            if self.live.transient and not self.console.is_interactive and not self.disable:
                self.live.stop()
                return
            super().stop()

    # the words end the line and take the room the spinner, label, bar, counts and times leave them
    # (about 58 columns), cut short with an ellipsis: else rich cuts the times short instead
    words = Column(no_wrap=True, overflow="ellipsis", max_width=max(12, err_console.real.width - 58))

    class Working(SpinnerColumn):
        # one step can take many seconds with nothing to count (oxipng encoding one large page, a
        # placement tried): the spinner turns while a task is under way (some of it done, or of no
        # known total), so a bar that stands still is seen working (rich redraws it ten times a
        # second); a task done, or waiting for its first step (a later phase), shows none
        def render(self, task):
            if task.finished or (not task.completed and task.total is not None):
                return self.finished_text
            return super().render(task)

    # braille dots where the console encodes them; a console in ASCII or a code page (where rich
    # draws the bar in hyphens) would get each dot escaped, six characters wide
    working = Working("dots" if err_console.real.encoding.lower().startswith("utf") else "line", finished_text=" ")

    class Done(MofNCompleteColumn):
        # steps that are work, not things (a task made with percent=True: packing's): done in percent
        def render(self, task):
            if task.fields.get("percent"):
                return Text(f"{task.percentage:>3.0f}%", style="progress.percentage")
            return super().render(task)

    class Remaining(TimeRemainingColumn):
        # rich's estimate stands still between steps, and one step of work can take many seconds
        # (a large page encoded): counted down from the last step (its time: the field ``since``)
        def render(self, task):
            left, since = task.time_remaining, task.fields.get("since")
            if left is None or since is None or not task.fields.get("percent") or task.finished:
                return super().render(task)
            left = max(0, int(left - (task.get_time() - since)))
            return Text(f"{left // 3600:d}:{left // 60 % 60:02d}:{left % 60:02d}", style="progress.remaining")

    if phases:
        return Bars(working, TextColumn("[bold]{task.description:<8}"), BarColumn(bar_width=16), Done(),
                    TimeElapsedColumn(), TextColumn("ETA"), Remaining(),
                    TextColumn("{task.fields[project]}", table_column=words), console=err_console.real,
                    transient=transient)
    return Bars(working, TextColumn(f"[bold]{label}"), BarColumn(), Done(), TimeElapsedColumn(),
                TextColumn("ETA"), Remaining(), TextColumn("{task.description}", table_column=words),
                console=err_console.real, transient=transient)


def console_text(name) -> str:
    """A name or message from a disk or a project (a file, a project, an animation, an error
    naming them) as rich console text: its markup and control characters escaped
    (:func:`~spinemesh.errors.escaped`). The console and the bars read text as rich markup: a
    file named ``a[/]b.png`` ended ``mesh FOLDER`` in a MarkupError traceback, and a newline in
    a name split one error line in two."""
    from rich.markup import escape

    from ..errors import escaped

    return escape(escaped(str(name)))


def shortened_text(name, width: int) -> str:
    """:func:`console_text` of ``name`` shortened to ``width`` characters as the bars and tables
    show it (:func:`spinemesh.runs.short_names`): its control characters escaped first, so that
    an ESC, BEL or carriage return in a project's name reaches no terminal raw, and the width
    counts what is shown."""
    from ..errors import escaped
    from ..runs import short_names

    text = escaped(str(name))
    return console_text(short_names([text], width)[text])


def phase_progress(bars):
    """A :class:`spinemesh.upgrade.progress.Progress` that moves ``bars`` (:func:`progress_bar` with
    ``phases``: one task per phase, made when its steps are first added); ``upgrade`` and ``weights``."""
    from ..upgrade.progress import IN_WORK, Progress

    def shown(name: str) -> str:
        return shortened_text(name, 20)  # the bars keep their room at 80 columns

    class Bars(Progress):
        def __init__(self) -> None:
            self.tasks: dict[str, int] = {}
            self.current = ""
            self.ahead: set[str] = set()  # phases that name their own project (a library's meshing ahead)

        def add(self, phase: str, steps: int, project: str | None = None) -> None:
            if phase not in self.tasks:
                self.tasks[phase] = bars.add_task(phase, total=0, project=self.current, percent=phase in IN_WORK)
            task = self.tasks[phase]
            bars.update(task, total=(bars.tasks[task].total or 0) + steps)
            if project is not None:
                self.ahead.add(phase)
                bars.update(task, project=shown(project))

        def advance(self, phase: str, steps: int = 1) -> None:
            if phase in self.tasks:
                bars.advance(self.tasks[phase], steps)
                bars.update(self.tasks[phase], since=bars.get_time())

        def step(self, phase: str, what: str, item: str = "") -> None:
            # the words first (a narrow terminal cuts the end), then the item, under its project
            # (a library run), until the next project
            if phase in self.tasks:
                where = shortened_text(item, 30) if item else ""
                where = f"{self.current}/{where}" if self.current and where else where or self.current
                bars.update(self.tasks[phase], project=f"{console_text(what)}: {where}" if where else console_text(what))

        def project(self, name: str) -> None:
            self.current = shown(name)
            for phase, task in self.tasks.items():
                if phase not in self.ahead:
                    bars.update(task, project=self.current)

    return Bars()


def finite(value: Optional[float]) -> Optional[float]:
    """Option callback: a finite number (None passes); click's ``min=``/``max=`` let NaN through."""
    if value is not None and not math.isfinite(value):
        raise typer.BadParameter(f"must be a finite number, not {value:g}")
    return value


def positive_finite(value: Optional[float]) -> Optional[float]:
    """Option callback: a number that is finite and above zero (None passes)."""
    if value is not None and not (math.isfinite(value) and value > 0):
        raise typer.BadParameter(f"must be a finite number above 0, not {value:g}")
    return value


def _print_version(value: bool) -> None:
    if value:
        from ..files.guard import OutputGuard

        OutputGuard([]).check_standard_output("the version")  # all it makes: refused where it is closed
        print(f"spinemesh {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[bool, typer.Option("--version", callback=_print_version, is_eager=True,
                                          help="Print the version and exit.")] = False,
) -> None:
    """Automatic triangle meshes for Spine projects.

    \b
    Example: spinemesh upgrade project/ --out meshed/ --preview meshed-preview/
    """


__all__ = ["app", "console", "err_console", "progress_bar", "phase_progress", "finite", "positive_finite", "Preset", "MaskSource",
           "Annotated", "Optional"]
