"""Counts and the paper's four dataset plots (sec. 4, figure "Dataset statistics")."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np

from ..errors import SpineMeshError
from ..skeleton_version import major_minor
from .format import Dataset


def dataset_stats(ds: Dataset) -> dict:
    """Counts and distributions of a data set, from one pass over the index.

    Returns
    -------
    dict
        ``samples``; ``by_type``, ``by_split``, ``by_version`` (major.minor), ``by_game``,
        ``by_project`` (Counters); ``games_by_split`` (split -> number of games); ``max_side`` (S,) int
        array of max(width, height) in pixels per sample; ``n_vertices`` (M,) int array, one
        per mesh sample; ``pixels`` total image area.
    """
    by = {k: Counter() for k in ("type", "split", "version", "game", "project")}
    games: dict[str, set] = {"train": set(), "val": set()}
    sides, verts, pixels = [], [], 0
    for row in ds.rows():
        for k in ("type", "split", "game", "project"):
            by[k][row[k]] += 1
        # "3.8-from-4.0.64", "3.8.99" -> "3.8": editors write many patch versions.
        known = major_minor(row["version"])
        by["version"]["%d.%d" % known if known else "?"] += 1
        games[row["split"]].add(row["game"])
        sides.append(max(row["width"], row["height"]))
        pixels += row["width"] * row["height"]
        if row["type"] == "mesh":
            verts.append(row["n_vertices"])
    return {"samples": sum(by["type"].values()),
            **{f"by_{k}": c for k, c in by.items()},
            "games_by_split": {k: len(v) for k, v in games.items()},
            "max_side": np.asarray(sides, np.int64), "n_vertices": np.asarray(verts, np.int64),
            "pixels": pixels}


def plot_stats(stats: dict, out_dir: str | Path) -> list[Path]:
    """Write the paper's four panels as PNG files; returns their paths.

    ``samples_per_game.png`` (histogram of samples per game), ``type_share.png`` (region vs
    mesh pie with counts), ``vertex_counts.png`` (mesh vertex counts, median line),
    ``image_sizes.png`` (max image side in pixels, median line). The folder is marked as
    spinemesh's; once the panels are written, an earlier run's files there that this one did
    not write again, and a killed run's temporary files, are removed
    (:func:`~spinemesh.written_folder.rewriting_folder`), never a file spinemesh did not write.
    """
    from ..written_folder import rewriting_folder

    with rewriting_folder(out_dir):
        return _plot_panels(stats, Path(out_dir))


#: What a run without matplotlib (the ``stats`` extra) is told of the plots.
PLOTS_NEED = "dataset-stats plots need matplotlib: pip install 'spinemesh[stats]'"


def can_plot() -> bool:
    """Whether matplotlib, which draws the plots, is installed (the ``stats`` extra)."""
    try:
        _matplotlib()
    except ImportError:
        return False
    return True


def _matplotlib():
    """matplotlib, imported with its configuration and font cache in a temporary folder of this
    process, removed at its exit, unless ``MPLCONFIGDIR`` names one: it made ``~/.config/matplotlib``
    and ``~/.cache/matplotlib`` in the user's home (nothing else is written there), and printed
    four lines of warning where home is read-only. Building the font list anew costs about a second.

    Raises
    ------
    ImportError
        Without the ``stats`` extra.
    """
    import os
    import sys

    if "matplotlib" not in sys.modules and "MPLCONFIGDIR" not in os.environ:
        import atexit
        import shutil
        import tempfile

        folder = tempfile.mkdtemp(prefix="spinemesh-matplotlib-")
        atexit.register(shutil.rmtree, folder, True)
        os.environ["MPLCONFIGDIR"] = folder
    import matplotlib

    return matplotlib


def _plot_panels(stats: dict, out_dir: Path) -> list[Path]:
    """:func:`plot_stats`'s panels, written into ``out_dir``."""
    try:
        matplotlib = _matplotlib()
    except ImportError:
        raise SpineMeshError(PLOTS_NEED) from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    from ..files.atomic import atomic_write_bytes
    from ..written_folder import mark_written_folder

    out_dir = Path(out_dir)
    written = []
    mark_written_folder(out_dir)  # before its first plot: a later run writes into it again

    def save(fig, name: str) -> None:
        import io

        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
        plt.close(fig)
        atomic_write_bytes(out_dir / name, buf.getvalue())
        written.append(out_dir / name)

    per_game = np.asarray(sorted(stats["by_game"].values()), np.int64)
    fig, ax = plt.subplots(figsize=(6, 4))
    if len(per_game):
        ax.hist(per_game, bins=min(40, max(5, len(per_game))), color="#4c72b0")
    ax.set(xlabel="samples per game", ylabel="games",
           title=f"(a) {stats['samples']:,} samples from {len(per_game)} games")
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))  # a count of games is whole
    save(fig, "samples_per_game.png")

    types = stats["by_type"]
    fig, ax = plt.subplots(figsize=(5, 5))
    labels = [t for t in ("region", "mesh") if types.get(t)]
    if labels:
        counts = [types[t] for t in labels]
        ax.pie(counts, labels=[f"{t}\n{n:,}" for t, n in zip(labels, counts)], autopct="%1.1f%%",
               colors=["#4c72b0", "#dd8452"][:len(labels)], startangle=90)
    ax.set(title="(b) attachment type")
    save(fig, "type_share.png")

    for name, values, label, title in (
            ("vertex_counts.png", stats["n_vertices"], "vertices per mesh", "(c) mesh vertex counts"),
            ("image_sizes.png", stats["max_side"], "max image side (px)", "(d) image sizes")):
        fig, ax = plt.subplots(figsize=(6, 4))
        if len(values):
            ax.hist(values, bins=50, color="#55a868")
            med = float(np.median(values))
            ax.axvline(med, color="k", linestyle="--", label=f"median {med:g}")
            ax.legend()
        ax.set(xlabel=label, ylabel="samples", title=title)
        save(fig, name)
    return written
