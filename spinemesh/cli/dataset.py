"""``spinemesh dataset`` and ``spinemesh dataset-stats``: training data from Spine projects."""

from __future__ import annotations

from pathlib import Path

import typer

from ..errors import escaped
from ..limits import MAX_JOBS
from ._app import Annotated, Optional, app, console_text, console, err_console, progress_bar


@app.command()
def dataset(
    corpus: Annotated[list[Path], typer.Argument(metavar="FOLDER...", help="Folders holding Spine projects, at any depth.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Data set folder (created, or resumed).")],
    jobs: Annotated[Optional[int], typer.Option("--jobs", "-j", min=1, max=MAX_JOBS, help="Worker processes (default: the CPU "
                                                "cores this process may use).")] = None,
    dask: Annotated[Optional[str], typer.Option(
        "--dask", metavar="ADDRESS", help="Extract on a Dask cluster: a scheduler address (tcp://host:8786), a "
                                          "scheduler file, or 'local' (--jobs workers here). Same data set as a "
                                          "local run; needs the 'cluster' extra.")] = None,
    retry_failed: Annotated[bool, typer.Option(
        "--retry-failed", help="Read again projects that had errors in an earlier run.")] = False,
) -> None:
    """Extract every unique attachment image (region, mesh, sequence frames) with its mask
    (alpha > 128) and, for meshes, the artist's vertices in pixels, into tar shards and a
    JSONL index, split 90/10 by game. Re-running resumes and adds nothing twice.

    \b
    Example: spinemesh dataset studio-projects/ other-games/ --out ds/ --jobs 2
    """
    from ..cluster import available_cores
    from ..dataset import build_dataset
    from ..files.guard import check_outputs

    check_outputs(corpus, folders=[out])
    with progress_bar("projects", transient=True) as progress:
        task = progress.add_task("", total=None)

        def on_project(name: str, done: int, total: int) -> None:
            progress.update(task, completed=done, total=total, description=console_text(name))

        summary = build_dataset(corpus, out, jobs=jobs or available_cores(), retry_failed=retry_failed,
                                on_project=on_project, dask=dask)



    from ..dataset import dataset_stats, open_dataset

    whole = dataset_stats(open_dataset(out))
    if summary.projects:  # a re-run reads none: "0 new samples from 0 projects in 0.0 s" said nothing
        rate = summary.samples / summary.seconds if summary.seconds else 0.0
        console.print(f"[bold]{summary.samples:,}[/] new samples from {summary.projects} projects in "
                      f"{summary.seconds:.1f} s ({rate:.0f} samples/s); {summary.projects_done_before} projects "
                      f"done before; data set now holds {summary.total_samples:,} samples in {console_text(str(out))}")
    if summary.samples:
        console.print(_count_table("new samples", "by type", "count", [
            *sorted(summary.by_type.items()), *((f"split {k}", n) for k, n in sorted(summary.by_split.items()))]))
    else:  # a re-run: say what is already there rather than print an empty table
        console.print(f"nothing new: the data set already holds {whole['samples']:,} samples from "
                      f"{len(whole['by_project'])} projects of {len(whole['by_game'])} games "
                      f"({', '.join(f'{k} {n:,}' for k, n in sorted(whole['by_split'].items()))})")
    _warn_empty_sides(whole, out)
    if summary.by_project:
        console.print(_count_table("new samples by project", "project", "samples",
                                   sorted(summary.by_project.items())))
    if summary.skipped:
        console.print(_count_table("skipped images", "why", "count", summary.skipped.most_common()))
    _print_problems(summary, out)
    if summary.lost:  # a worker died on them twice: the data set lacks them until --retry-failed
        from ..runs import EXIT_PARTIAL

        raise typer.Exit(EXIT_PARTIAL)


def _count_table(title: str, what: str, counted: str, rows):
    """A two-column table of ``(label, count)`` rows, counts with thousands separators; the labels
    (project folders, reasons) shown as they are, never read as markup."""
    from rich.table import Table


    t = Table(title=title)
    t.add_column(what)
    t.add_column(counted, justify="right")
    for k, n in rows:
        t.add_row(console_text(str(k)), f"{n:,}")
    return t


def _warn_empty_sides(whole: dict, out: Path) -> None:
    """A warning for each side of the game split that holds no game (``whole``: the data set's stats)."""
    for side in ("train", "val"):
        if not whole["games_by_split"].get(side):
            err_console.print(f"warning: no game of {out} falls on the {side} side of the split "
                              f"({len(whole['by_game'])} games; the split is by a hash of the game name, "
                              f"so a data set of few games can leave one side empty)", markup=False)


def _print_problems(summary, out: Path) -> None:
    """The run's problems, the first 40 of them by name (the rest are in ``projects.jsonl``)."""
    from ..errors import escaped  # names from the corpus: a newline in one cannot forge a line

    if summary.errors:
        err_console.print(f"[yellow]{len(summary.errors)} problem(s) in {summary.projects_with_errors} "
                          f"project(s); their other files were used:[/]")
        for e in summary.errors[:40]:
            err_console.print(f"  {escaped(e)}", markup=False, highlight=False)
        if len(summary.errors) > 40:
            err_console.print(escaped(f"  ... and {len(summary.errors) - 40} more (see {out}/projects.jsonl)"),
                              markup=False)


@app.command("dataset-stats")
def dataset_stats_cmd(
    ds: Annotated[Path, typer.Argument(metavar="DS", help="Data set folder written by `spinemesh dataset`.")],
    plots: Annotated[Optional[Path], typer.Option("--plots", help="Folder for the PNG plots "
                                                  "(default: DS/stats).")] = None,
) -> None:
    """Counts, image sizes and mesh vertex counts of a data set, with the paper's four
    dataset plots as PNG (samples per game, region/mesh share, vertex counts, image sizes).

    \b
    Example: spinemesh dataset-stats ds/ --plots ds/stats
    """
    import numpy as np
    from rich.table import Table

    from ..dataset import dataset_stats, open_dataset, plot_stats
    from ..dataset.stats import PLOTS_NEED, can_plot
    from ..errors import SpineMeshError
    from ..files.guard import check_outputs
    from ..words import counted
    from ..written_folder import check_written_folder

    # the counts, which no plot holds, never to a closed standard output; --plots not a file, not a symlink
    check_outputs([], folders=[plots], product="the counts")
    plotting = can_plot()
    if plots is not None and not plotting:  # asked for: refused before any work
        raise SpineMeshError(f"--plots: {PLOTS_NEED}")
    if plots is not None:  # the default, DS/stats, lies in the data set, spinemesh's folder
        check_written_folder(plots, "--plots folder", "plots")  # a folder of a user's files: refused
    stats = dataset_stats(open_dataset(ds))
    console.print(f"{ds}: {counted(stats['samples'], 'sample')} from {counted(len(stats['by_project']), 'project')} "
                  f"of {counted(len(stats['by_game']), 'game')}", highlight=False, markup=False)
    t = Table()
    t.add_column("")
    t.add_column("samples", justify="right")
    for key in ("by_type", "by_split", "by_version"):
        for k, n in sorted(stats[key].items()):
            t.add_row(f"{key[3:]} {k or '?'}", f"{n:,}")
    for k, n in sorted(stats["games_by_split"].items()):
        t.add_row(f"games in {k}", f"{n:,}")
    console.print(t)
    t = Table(title="distributions")
    for col in ("", "min", "median", "p90", "max", "mean"):
        t.add_column(col, justify="right")
    for label, v in (("max image side (px)", stats["max_side"]), ("vertices per mesh", stats["n_vertices"])):
        if len(v):
            t.add_row(label, str(v.min()), f"{np.median(v):g}", f"{np.percentile(v, 90):g}", str(v.max()),
                      f"{v.mean():.1f}")
    console.print(t)
    console.print(f"total image area {stats['pixels'] / 1e6:.1f} Mpx")
    if not plotting:  # the counts are the command's answer; the plots an extra's (exit 0, as documented)
        err_console.print(f"warning: no plots written: {PLOTS_NEED}", highlight=False, markup=False)
        return
    written = plot_stats(stats, plots or Path(ds) / "stats")
    console.print(escaped("plots: " + ", ".join(str(p) for p in written)), markup=False)
