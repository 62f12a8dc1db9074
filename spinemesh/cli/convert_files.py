"""What ``spinemesh convert`` does, without typer: one skeleton file to another format.

:func:`convert_files` is the command's whole work, called by the typer command in
:mod:`.convert`. :func:`run_plain_convert` lets the console script run a plain
``spinemesh convert SOURCE TARGET [--keep-binary-info]`` without importing typer at all
(about 30 ms of a 90 ms run on a large skeleton, issue 19); anything else (``--help``, a
missing source, an option it does not know, ``--``) goes to the typer command, which gives
the usual help and errors.
"""

from __future__ import annotations

import gc
import os
import sys
from pathlib import Path

_BINARY_SUFFIXES = (".skel", ".skel.bytes")
#: JSON skeleton names written: the editor's, Unity's and Godot's (every one the readers take).
_JSON_SUFFIXES = (".json", ".json.txt", ".spine-json")
KEEP_BINARY_INFO = "--keep-binary-info"


def is_binary_name(path: Path) -> bool:
    """Whether a file name says binary skeleton (``.skel``, ``.skel.bytes``)."""
    return path.name.lower().endswith(_BINARY_SUFFIXES)


def convert_files(source: Path, target: Path, keep_binary_info: bool = False) -> str:
    """Convert the skeleton ``source`` to ``target``, whose extension picks the format; return
    the line to print (``wrote TARGET (JSON, Spine 4.2.22)``).

    Raises
    ------
    SpineMeshError
        For an unreadable source, a refused target (onto the source, through a symlink) or a
        target extension that is neither ``.skel``, ``.skel.bytes`` nor ``.json``.
    """
    from ..errors import SpineMeshError
    from ..files.atomic import atomic_write_bytes, atomic_write_text
    from ..files.guard import check_outputs
    from ..files.inputs import existing, regular_file
    from ..skeleton import SKELETON_SUFFIXES, dumps_skeleton, load_skeleton, spine_version
    from ..skeleton_binary.enums import EXTRA
    from ..skeleton_check import animations_keyed_twice

    regular_file(existing(source), "skeleton")  # one line naming it, as every command says it
    check_outputs([source], files=[target])  # never onto the source, never through a symlink
    try:
        doc = load_skeleton(source)
    except SpineMeshError:
        if not source.name.lower().endswith((*SKELETON_SUFFIXES, ".skel.txt")):  # .skel.txt: read as binary
            from ..project import find_project

            # an atlas or a page image was read as a binary skeleton ("expected a Spine version
            # string in the header"): refused as every command refuses it, naming the skeletons
            # beside it; a binary skeleton of another name (``hero.bytes``) is read as it was
            find_project(source, folder_taken=False)
        raise
    _refuse_unusable_attachment(doc, source)
    for line in animations_keyed_twice(doc):  # both paths (typer or not) say it on stderr
        print(f"warning: {source}: {line}", file=sys.stderr)
    if is_binary_name(target):
        from ..errors import SkelFormatError
        from ..skeleton_binary import encode_skel

        try:
            data = encode_skel(doc)
        except SkelFormatError as e:
            # what the binary layout cannot hold came from the source: name it, not a target
            # that is never written
            raise SpineMeshError("cannot be written as a binary skeleton: "
                                 + e.message.removeprefix("cannot write: "), source) from None
        atomic_write_bytes(target, data)
        kind = "binary"
    elif target.name.lower().endswith(_JSON_SUFFIXES):  # Unity's hero.json.txt, Godot's hero.spine-json
        if not keep_binary_info:
            doc = {k: v for k, v in doc.items() if k != EXTRA}
        numbers = None
        if is_binary_name(source):
            from ..skeleton_binary import Float32Text

            numbers = Float32Text  # float32 values as their shortest decimals, not float64 expansions
        atomic_write_text(target, dumps_skeleton(doc, target, numbers=numbers))
        kind = "JSON"
    else:
        raise SpineMeshError(f"target must end in {', '.join(_BINARY_SUFFIXES)} (binary) or "
                             f"{', '.join(_JSON_SUFFIXES)} (JSON)", target)
    return f"wrote {target} ({kind}, Spine {spine_version(doc) or '?'})"


def say_converted(line: str) -> None:
    """``convert``'s line on standard output (``wrote x.skel ...``); where standard output is closed
    (``>&-``), the warning every command whose files are what it makes gives: it was dropped in
    silence (``print`` and ``typer.echo`` write nothing to a closed standard output)."""
    if sys.stdout is None:
        from ..files.guard import STANDARD_OUTPUT_CLOSED

        print(f"warning: {STANDARD_OUTPUT_CLOSED}", file=sys.stderr)
    else:
        print(line)


def _refuse_unusable_attachment(doc: dict, source: Path) -> None:
    """Refuse, naming ``source`` and the field, a skeleton with an attachment the program cannot
    use: a number no float32 holds, or a field written twice, which the runtimes read
    differently (written once, the converted file would draw as one of them only)."""
    from ..errors import SpineMeshError
    from ..skeleton import checked_attachments

    for _, problem in checked_attachments(doc):
        if problem:
            raise SpineMeshError(f"not converted: {problem}", source)


def run_plain_convert(args: list[str]) -> bool:
    """Run ``convert`` for arguments that need no parsing; False (nothing done) for any other.

    Plain means: two paths not starting with ``-``, the source an existing readable file (what
    :func:`convert_files` checks), and at most the ``--keep-binary-info`` flag. Errors of the work
    itself are raised as from the typer command.
    """
    keep = KEEP_BINARY_INFO in args
    paths = [a for a in args if a != KEEP_BINARY_INFO]
    if len(paths) != 2 or args.count(KEEP_BINARY_INFO) > 1 or any(not p or p.startswith("-") for p in paths):
        return False
    source, target = map(Path, paths)
    if not (source.is_file() and os.access(source, os.R_OK)):
        return False
    # The process ends with this command, whose ~100,000 objects hold no reference cycle: the
    # cyclic collector would only walk them again and again while they are made (~3 ms of 90),
    # and the full collection the interpreter runs at exit would walk every module's objects
    # (~4 ms): frozen, they are left out of it.
    gc.disable()
    say_converted(convert_files(source, target, keep))
    gc.freeze()
    return True
