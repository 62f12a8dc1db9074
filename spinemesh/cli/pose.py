"""``spinemesh pose``: bone world transforms and attachment world vertices of an animation at given times."""

from __future__ import annotations

import math
import sys
from contextlib import contextmanager
from itertools import chain
from pathlib import Path

import typer

from ..errors import escaped
from ._app import Annotated, Optional, app, console_text, err_console, positive_finite

#: At most this many times in one call (each is a pose of every bone and attachment).
MAX_TIMES = 10_000


def _times(text: str) -> list[float]:
    """``--times``: comma-separated seconds, each finite and not negative."""
    out = []
    for part in text.split(","):
        part = part.strip()
        if not part:
            continue
        try:
            t = float(part)
        except ValueError:
            raise typer.BadParameter(f"{part!r} is not a number of seconds", param_hint="--times") from None
        if not math.isfinite(t) or t < 0:
            raise typer.BadParameter(f"{part!r}: times must be finite and not negative", param_hint="--times")
        out.append(t)
    if not out:  # `--times ""` (a script's empty variable): the animation was not posed at all, exit 0
        raise typer.BadParameter(f"{text!r} names no time; give one or more seconds, 0 for the start",
                                 param_hint="--times")
    if len(out) > MAX_TIMES:
        raise typer.BadParameter(f"{len(out)} times; at most {MAX_TIMES}", param_hint="--times")
    return out


@app.command()
def pose(
    skeleton: Annotated[Path, typer.Argument(metavar="SKELETON", help="Skeleton file (.json or .skel).")],
    animation: Annotated[Optional[str], typer.Option("--animation", "-a", metavar="NAME",
                                                     help="Animation to sample (default: the setup pose only).")] = None,
    times: Annotated[str, typer.Option(metavar="SECONDS", help="Comma-separated track times in seconds; the "
                                       "animation loops, reached in steps of 1/FPS s as a game loop does.")] = "0",
    skin: Annotated[Optional[str], typer.Option(metavar="NAME", help="Skin to show (default: the default skin).")] = None,
    atlas: Annotated[Optional[Path], typer.Option(metavar="ATLAS", help="Atlas whose regions place the region "
                                                  "quads (default: the atlas beside the skeleton holding its images).")] = None,
    fps: Annotated[float, typer.Option(min=1, max=10_000, callback=positive_finite,
                                       help="Game-loop steps per second used to reach each time.")] = 60.0,
    out: Annotated[Optional[Path], typer.Option("--out", "-o", metavar="FILE",
                                                help="Write the JSON here (default: standard output).")] = None,
) -> None:
    """Write the pose of an animation at given times: every bone's world transform and every
    drawn attachment's world vertices, as the Spine runtimes compute them.

    The JSON has the layout of the official-runtime dump: the setup pose, then one pose per
    time, each with "bones" (name: [a, b, c, d, worldX, worldY]) and "attachments" (drawn
    slots in draw order: slot, attachment, type, blend, colour, world vertices, uvs in the
    original image, triangles). Physics (4.2, 4.3) is stepped from time 0 as a game loop steps it.

    \b
    Example: spinemesh pose project/hero.json --animation run --times 0.2,0.5 --out pose.json
    Example: spinemesh pose project/hero.skel -a walk --times 0,0.1,0.2 --skin red --out walk.json
    """
    from ..anim import Sampler, atlas_regions
    from ..anim.dump import dump_labels
    from ..atlas import read_atlas
    from ..errors import SpineMeshError
    from ..files.guard import check_outputs
    from ..files.inputs import project_folder
    from ..limits import MAX_POSE_STEPS
    from ..project import find_project
    from ..runs import EXIT_PARTIAL
    from ..skeleton import load_skeleton
    from ..words import counted

    seconds = _times(times)
    if animation is not None and seconds and max(seconds) * fps > MAX_POSE_STEPS:
        raise typer.BadParameter(f"{max(seconds):g} s at {fps:g} steps per second is over {MAX_POSE_STEPS:,} "
                                 "game-loop steps; give times within the animation's loop", param_hint="--times")
    project = find_project(skeleton, folder_taken=False)
    # nor onto the --atlas read (standard output too)
    check_outputs([project_folder(skeleton), atlas], files=[out],
                  product="the poses" if out is None else None)
    stdout = sys.stdout
    doc = load_skeleton(skeleton)
    anims = [str(a) for a in (doc.get("animations") or {})]
    known = ", ".join(anims[:20]) + (", ..." if len(anims) > 20 else "") if anims else "none"
    if animation is not None and animation not in anims:
        raise SpineMeshError(f"no animation {animation!r} (the skeleton has: {known})", skeleton)
    if animation is None and any(seconds):
        # without an animation there is nothing to sample at a time: the times were dropped in
        # silence and the file held the setup pose alone ("1 poses")
        raise SpineMeshError(f"--times {times} samples an animation: add --animation NAME (the skeleton has: "
                             f"{known}); without it the setup pose alone is written", skeleton)
    skins = [name for name in _skin_names(doc)]
    if skin is not None and skin not in skins:
        raise SpineMeshError(f"no skin {skin!r} (the skeleton has: {', '.join(skins[:20]) or 'none'})", skeleton)
    undrawn = _say_undrawn(doc, skin, skeleton)
    atlases = [read_atlas(atlas)] if atlas is not None else _project_atlases(doc, skeleton, project)
    sampler = Sampler(doc, skin, atlas_regions(atlases) if atlases else None)
    _check_pose_bounds(sampler, animation, seconds, fps, skeleton, out)
    unplayable = _say_unplayable(sampler, animation, skeleton)
    not_numbers = _write_poses(sampler, animation, seconds, fps, skeleton, out, stdout)
    if not_numbers:
        err_console.print(escaped(f"warning: {not_a_number_said(not_numbers, skeleton)}"), highlight=False, markup=False,
                          soft_wrap=True)
    if out is not None:
        err_console.print(escaped(f"{out}: {counted(len(dump_labels(animation, seconds)), 'pose')}"), highlight=False,
                          markup=False)
    if undrawn or unplayable:
        raise typer.Exit(EXIT_PARTIAL)


def _say_undrawn(doc: dict, skin: str | None, skeleton: Path) -> int:
    """Warn, one line each (the first :data:`~spinemesh.words.MAX_UNUSABLE_SAID`), of the
    attachments that draw an image in the skin posed (and the default skin) whose fields cannot
    be used, which the poses leave undrawn; returns how many. (A path attachment's are said by
    the bones its constraint leaves flagged.)"""
    from ..skeleton import IMAGE_TYPES, checked_attachments
    from ..words import unusable_said

    skins = {"default", skin or "default"}
    problems = [problem for ref, problem in checked_attachments(doc)
                if problem and ref.skin in skins and ref.type in IMAGE_TYPES]
    for line in unusable_said(problems, skeleton, "{problem}; not drawn", "{more} more attachments not drawn"):
        err_console.print(escaped(f"warning: {line}"), highlight=False, markup=False, soft_wrap=True)
    return len(problems)


def _say_unplayable(sampler, animation: str | None, skeleton: Path) -> int:
    """Warn, one line each (the first :data:`~spinemesh.words.MAX_UNUSABLE_SAID`), of the 4.x
    curves of ``animation`` that no runtime plays (posed linear here, a pose no game shows);
    returns how many."""
    from ..anim import POSE_ERRORS
    from ..anim.curves import unplayable_said
    from ..words import unusable_said

    if animation is None:
        return 0
    try:
        problems = sampler.animation(animation)[0].unplayable
    except POSE_ERRORS:
        return 0  # said where the poses are made
    said = [unplayable_said(animation, problem, "posed linear here") for problem in problems]
    for line in unusable_said(said, skeleton, "{problem}", "{more} more curves no runtime plays"):
        err_console.print(escaped(f"warning: {line}"), highlight=False, markup=False, soft_wrap=True)
    return len(problems)


def _project_atlases(doc: dict, skeleton: Path, project) -> list:
    """The project's atlases that serve the skeleton; without one, a warning says that region
    quads are drawn over their whole images, and why: an atlas that is there but cannot be used
    is named with the atlas reader's own error, else none was found."""
    from ..project import image_source_for

    atlases = list(getattr(image_source_for(doc, skeleton, project), "atlases", None) or [])
    if not atlases:
        broken = list(project.broken_atlases.values())
        what = (f"atlas not used: {broken[0]}" + (f" (and {len(broken) - 1} more)" if len(broken) > 1 else "")
                if broken else "no atlas found beside the skeleton")
        err_console.print(f"[yellow]warning:[/] {console_text(what)}: region quads are drawn over their whole images "
                          "(as if no whitespace was stripped)", highlight=False, soft_wrap=True)
    return atlases


def _within_the_cap(pieces, skeleton: Path):
    """The pieces of the JSON as they come, refused in one line naming the skeleton as soon as
    they pass :data:`~spinemesh.limits.MAX_POSE_OUTPUT_BYTES`: the estimate made before sampling
    (:func:`_check_pose_bounds`) measures the setup pose, and an animation may draw far more (a
    setup pose that draws nothing bounds nothing). To ``--out``, the file is then not written."""
    from ..errors import SpineMeshError
    from ..limits import MAX_POSE_OUTPUT_BYTES

    written = 0
    for piece in pieces:
        written += len(piece) if piece.isascii() else len(piece.encode("utf-8"))
        if written > MAX_POSE_OUTPUT_BYTES:
            raise SpineMeshError(f"--times: the poses passed {MAX_POSE_OUTPUT_BYTES / 2**30:,.4g} GiB of JSON, the "
                                 "limit (they draw more than the setup pose the estimate measured); give fewer times",
                                 skeleton)
        yield piece


def _echo_pieces(pieces, stdout) -> None:
    """Write the pieces to standard output as they come; what the system refuses (a full disk)
    ends in one line naming standard output. A reader that closed the pipe (``| head``) ends the
    run quietly, as the command line's own handler ends it (exit status 1). The document is UTF-8
    bytes (what JSON is), whatever the console's encoding: a name that encoding cannot write
    (``PYTHONIOENCODING=ascii``) ended the run in a traceback."""
    import errno

    from ..errors import OutputError

    try:
        for piece in pieces:
            typer.echo(piece.encode("utf-8"), nl=False, file=stdout)
    except OSError as e:
        if e.errno == errno.EPIPE:
            raise
        raise OutputError(f"cannot write: {e.strerror or e}", "standard output") from None


def _echo_whole(pieces, stdout) -> None:
    """The document on standard output whole or not at all: the pieces are held in an anonymous
    temporary file in the system's temporary folder (on disk: still one pose in memory; the system
    removes it however the run ends) and copied to standard output once the last one is made.

    A pose that fails part way leaves nothing on standard output, only its error line on stderr
    and exit status 2, so a script reads one whole JSON document or none, in the documented
    layout (the same bytes as ``--out``). A temporary folder that cannot hold them ends in one
    line naming it.
    """
    import tempfile

    with _holding():
        spool = tempfile.TemporaryFile("w+", encoding="utf-8", newline="")  # newline="": "\n" as made
    with spool:
        for piece in pieces:  # a pose's own error (made here) passes as it is: only the writes are held
            with _holding():
                spool.write(piece)
        spool.seek(0)
        _echo_pieces(iter(lambda: spool.read(1 << 20), ""), stdout)


@contextmanager
def _holding():
    """What the system refuses while the poses are held for standard output (no temporary file,
    a full temporary folder) as one line naming the temporary folder."""
    import tempfile

    from ..errors import OutputError

    try:
        yield
    except OSError as e:
        raise OutputError(f"cannot hold the poses for standard output: {e.strerror or e}",
                          tempfile.gettempdir()) from None


def _write_poses(sampler, animation: str | None, seconds: list[float], fps: float, skeleton: Path,
                 out: Path | None, stdout) -> dict[str, list[str]]:
    """Write the dump (to ``out``, else to ``stdout``) with a bar; returns the bones a pose left
    without a number, bone name -> the poses' labels."""
    from ..anim.dump import dump_head, dump_poses
    from ..files.atomic import atomic_write_pieces
    from ..files.strict_json import strict_json_pieces
    from ._app import progress_bar

    # The JSON is written as a stream, one pose at a time (only one is held); to --out through a
    # temporary file renamed when the last pose is written, so that a refusal leaves no file; to
    # standard output through an anonymous temporary file copied there once the last pose is
    # written, so that a refusal leaves nothing there either (_echo_whole).
    # Standard output is taken before the bar starts: on a terminal the bar replaces sys.stdout
    # by a proxy that holds text until a newline and then prints it on stderr.
    not_numbers: dict[str, list[str]] = {}
    with progress_bar("pose", transient=True) as bar:
        task = bar.add_task(console_text(animation or "setup"), total=1 + (len(seconds) if animation else 0))
        poses = _posed(dump_poses(sampler, animation, seconds if animation else [], fps,
                                  step=lambda: bar.advance(task)), animation, skeleton, not_numbers)
        head = dump_head(sampler, Path(skeleton).name, fps)  # its name: the same bytes from any folder
        pieces = _within_the_cap(chain(strict_json_pieces(head, "poses", poses, out if out is not None else skeleton),
                                       ["\n"]), skeleton)
        if out is None:
            _echo_whole(pieces, stdout)
        else:
            atomic_write_pieces(out, pieces)
    return not_numbers


def _posed(poses, animation: str | None, skeleton: Path, not_numbers: dict[str, list[str]]):
    """``poses`` (the dump's, made one by one), what the sampler cannot play refused in one line
    naming the skeleton (what the document's check let through); the bones a pose leaves without
    a number (written null) are added to ``not_numbers``, bone name -> the poses' labels."""
    from ..anim import POSE_ERRORS
    from ..errors import SpineMeshError

    try:
        for entry in poses:
            for name, numbers in entry["bones"].items():
                if None in numbers:
                    not_numbers.setdefault(name, []).append(entry["label"])
            yield entry
    except POSE_ERRORS as e:
        raise SpineMeshError(f"animation {animation!r} cannot be posed: {e}", skeleton) from None


def not_a_number_said(not_numbers: dict[str, list[str]], skeleton: Path) -> str:
    """One line naming the bones whose pose is not a number (the first few, and the poses where),
    written null: the runtime of the skeleton's version computes NaN there and draws nothing."""
    names = list(not_numbers)
    labels = list(dict.fromkeys(label for where in not_numbers.values() for label in where))
    bones = ", ".join(names[:5]) + (f" and {len(names) - 5} more" if len(names) > 5 else "")
    poses = ", ".join(labels[:3]) + (f" and {len(labels) - 3} more" if len(labels) > 3 else "")
    return (f"{skeleton}: {len(names)} bone{'s' if len(names) != 1 else ''} ({bones}) not a number in "
            f"{len(labels)} pose{'s' if len(labels) != 1 else ''} ({poses}): written null; the runtime of the "
            "skeleton's version computes no number there either (a degenerate pose, such as a scale of 0 above "
            "them) and draws nothing of them")


def _check_pose_bounds(sampler, animation: str | None, seconds: list[float], fps: float, skeleton: Path,
                       out: Path | None = None) -> None:
    """Refuse, naming the skeleton, a pose run whose physics replay or JSON would be over the limits
    (each time replays the game loop from 0 when physics keeps state), or whose JSON, estimated as
    the setup pose's size times the poses, would not fit in the space free where ``out`` is written
    (without ``out``: in the temporary folder that holds standard output's poses)."""
    import tempfile

    from ..anim import POSE_ERRORS
    from ..anim.dump import dump_labels
    from ..anim.pose import steps_of
    from ..errors import SpineMeshError
    from ..files.disk import free_bytes
    from ..files.strict_json import strict_json
    from ..limits import MAX_POSE_OUTPUT_BYTES, MAX_POSE_STEPS

    if animation is not None and sampler.physics:
        # each time replays the game loop from 0 (physics keeps state): the steps of all of them are bounded
        replayed = sum(steps_of(t, fps)[0] for t in set(seconds))
        if replayed > MAX_POSE_STEPS:
            raise SpineMeshError(f"--times: {len(set(seconds)):,} times replay {replayed:,} game-loop steps of "
                                 f"this skeleton's physics in all, over {MAX_POSE_STEPS:,}; give fewer or earlier times",
                                 skeleton)
    poses = len(dump_labels(animation, seconds))
    try:
        size = poses * len(strict_json(sampler.pose(None).to_dump(), None, skeleton)) if poses > 1 else 0
    except POSE_ERRORS as e:  # what the document's check let through and the sampler cannot pose
        raise SpineMeshError(f"the setup pose cannot be posed: {e}", skeleton) from None
    if size > MAX_POSE_OUTPUT_BYTES:
        raise SpineMeshError(f"--times: {poses:,} poses of this skeleton would write about {size / 2**20:,.0f} MiB of "
                             f"JSON, over the limit of {MAX_POSE_OUTPUT_BYTES / 2**30:,.0f} GiB; give fewer times", skeleton)
    # standard output's poses are held in the temporary folder first (_echo_whole)
    where = "where --out is" if out is not None else f"in the temporary folder {tempfile.gettempdir()} (TMPDIR)"
    free = free_bytes(out if out is not None else Path(tempfile.gettempdir()) / "poses.json") if size else None
    if free is not None and size > free:
        raise SpineMeshError(f"--times: {poses:,} poses of this skeleton would write about {size / 2**20:,.0f} MiB of "
                             f"JSON, more than the {free / 2**20:,.0f} MiB free {where}; give fewer times "
                             "or write elsewhere", skeleton)


def _skin_names(doc: dict) -> list[str]:
    from ..skeleton import iter_skins

    return [name for name, _ in iter_skins(doc)]
