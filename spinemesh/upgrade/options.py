"""What the user asked ``upgrade`` for, and the rules that follow from the options alone.

:class:`Options` is read by every stage; :func:`skip_reason` is the planning stage's first
test (the user's own filters), :meth:`Options.mesh_settings` part of every mesh's cache key.
"""

from __future__ import annotations

import fnmatch
import unicodedata
from dataclasses import dataclass, field
from pathlib import Path

from ..files.inside import as_written
from ..mesher.worth import DEFAULT_MIN_SAVING
from ..pack.atlas_pack import PageRules
from ..skeleton import AttachmentRef


@dataclass
class Options:
    """What the user asked for (see ``spinemesh upgrade --help``)."""

    preset: str = "default"
    mask: str = "auto"
    only: list[str] = field(default_factory=list)
    exclude: list[str] = field(default_factory=list)
    min_size: float = 0.0
    dry_run: bool = False
    jobs: int = 1
    dask: str | None = None
    images_out: Path | None = None
    images_in: Path | None = None
    overrides: dict = field(default_factory=dict)
    overwrite: bool = False
    repack: bool = False  # store sequence frames whole where one mesh cannot fit them trimmed
    pack: bool = False  # pack the written atlases anew by the upgraded meshes' outlines (spinemesh.pack)
    pack_rules: PageRules = field(default_factory=PageRules)  # the pages --pack may write
    pack_keep_files: bool = False  # --pack copies the atlases it keeps byte for byte (no lossless re-encode)
    # keep a region when its mesh would save less than this share of drawn pixels (or needs
    # too many vertices): spinemesh.mesher.worth; None meshes every region
    min_saving: float | None = DEFAULT_MIN_SAVING
    weights: str = "none"  # auto: bind and weight the upgraded meshes (spinemesh.rig)

    def mesh_settings(self) -> tuple:
        """What, besides the pixels, decides a mesh: part of every cache key."""
        overrides = {**self.overrides, "min_saving": self.min_saving}
        return (self.preset, mask_source_for_upgrade(self.mask), tuple(sorted(overrides.items())))


def mask_source_for_upgrade(mask: str) -> str:
    """The mask source that ``upgrade`` uses for ``--mask``.

    ``auto`` means alpha here: an atlas region is drawn by the runtime through its alpha (a
    page without alpha is drawn whole), so alpha is what keeps every drawn pixel inside the
    mesh. The network's guess (``model``) may cut drawn pixels off and is used only when asked.
    """
    return "alpha" if mask == "auto" else mask


def _matches(patterns: list[str], ref: AttachmentRef, paths: list[str]) -> bool:
    # in one Unicode form (a name from macOS is NFD, one typed elsewhere NFC: the same letters),
    # an image path's backslashes (a Windows export) as the folders they are
    names = [_nfc(n) for n in (ref.slot, ref.name, *paths, *map(as_written, paths))]
    return any(fnmatch.fnmatchcase(n, _nfc(p)) for p in patterns for n in names)


def _nfc(text: str) -> str:
    return unicodedata.normalize("NFC", str(text))


#: What :func:`skip_reason` says of a region that ``--only``/``--exclude`` leave alone.
NOT_SELECTED = ("not matched by --only", "matched by --exclude")


def skip_reason(ref: AttachmentRef, paths: list[str], options: Options) -> str:
    """Why the user's options leave this region alone (``""`` when they do not)."""
    if options.only and not _matches(options.only, ref, paths):
        return NOT_SELECTED[0]
    if options.exclude and _matches(options.exclude, ref, paths):
        return NOT_SELECTED[1]
    w, h = float(ref.attachment.get("width", 32)), float(ref.attachment.get("height", 32))
    if max(w, h) < options.min_size:
        return f"smaller than --min-size {options.min_size:g}"
    return ""
