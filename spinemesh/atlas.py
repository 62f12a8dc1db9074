"""Spine/libGDX texture atlases: read, model, write.

Two syntaxes exist and both are read and written back in the form they came in:

- the 3.x one: ``rotate: true|false``, ``xy:``, ``size:``, ``orig:``, ``offset:``, ``index:``,
  ``split:``, ``pad:``;
- the 4.x one: ``bounds:``, ``offsets:``, ``rotate: true|90|180|270``, and the page fields
  ``size:``, ``format:``, ``filter:``, ``repeat:``, ``pma:``, ``scale:``.

The model keeps every ``key: values`` entry of a page or region in file order, unknown keys
included, so writing a parsed atlas reproduces it. Geometry is derived from the entries on
demand (:meth:`AtlasRegion.geometry`), one rule for both syntaxes.

Coordinates: ``x, y`` is the top-left of the packed rectangle on the page (y down);
``width, height`` is the packed image *before* rotation, so a region rotated by 90 or 270
degrees occupies ``height x width`` page pixels. ``offset_x, offset_y`` is the whitespace
stripped at the left and at the *bottom* (libGDX counts y up) of the original image of size
``original_width x original_height``.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field
from pathlib import Path

from .errors import AtlasError, LimitError, SpineMeshError
from .files.inside import as_written
from .limits import MAX_ATLAS_REGIONS, MAX_ATLAS_SCALE, MIN_ATLAS_SCALE, check_file_size, check_image_size

#: Keys that start a 4.x-only entry; any of them marks an atlas as 4.x syntax.
_V4_KEYS = {"bounds", "offsets", "pma", "scale"}
#: The ``rotate:`` degrees the runtimes turn a region by.
_TURNS = (0, 90, 180, 270)


@dataclass(slots=True)
class Entry:
    """One ``key: v1, v2, ...`` line, with the formatting needed to write it back."""

    key: str
    values: list[str]
    indent: str = ""
    sep: str = ", "
    colon: str = ": "

    def line(self) -> str:
        return f"{self.indent}{self.key}{self.colon}{self.sep.join(self.values)}"


@dataclass
class RegionGeometry:
    """Where a region lies on its page and in its original image (all in page pixels)."""

    x: int
    y: int
    width: int
    height: int
    offset_x: int
    offset_y: int
    original_width: int
    original_height: int
    degrees: int

    @property
    def page_width(self) -> int:
        """Width of the rectangle the region occupies on the page."""
        return self.height if self.degrees in (90, 270) else self.width

    @property
    def page_height(self) -> int:
        return self.width if self.degrees in (90, 270) else self.height


class _Fields:
    """Lookup of a page's or region's ``key: values`` entries (the last entry of a key wins: the
    runtimes set fields line by line)."""

    __slots__ = ()

    entries: list[Entry]

    def get(self, key: str) -> list[str] | None:
        for e in reversed(self.entries):
            if e.key == key:
                return e.values
        return None


@dataclass(slots=True)
class AtlasRegion(_Fields):
    """A named region of a page. ``entries`` hold every field in file order."""

    name: str
    page: int
    entries: list[Entry] = field(default_factory=list)
    line: int = 0
    #: Why the region cannot be used (set by a lenient parse); :meth:`geometry` raises it.
    error: SpineMeshError | None = field(default=None, compare=False, repr=False)

    @property
    def index(self) -> int:
        v = self.get("index")
        return int(v[0]) if v else -1

    def geometry(self, source: str | None = None) -> RegionGeometry:
        """Geometry from either syntax.

        Raises
        ------
        AtlasError
            On malformed or negative numbers.
        LimitError
            When the packed or original size exceeds :mod:`spinemesh.limits`.
        """
        if self.error is not None:
            raise self.error
        # The runtimes set a region's fields line by line, so a field written twice, or
        # bounds: and xy: both, take the later line (read by key, the first one was taken).
        got: dict[str, int] = {}
        for e in self.entries:
            fields = _GEOMETRY_FIELDS.get(e.key)
            if fields is not None:
                got.update(zip(fields, _ints(self, e.key, e.values, len(fields), source)))
            elif e.key == "rotate":
                got["degrees"] = _degrees(self, e.values, source)
        if not {"x", "y", "w", "h"} <= got.keys():
            raise AtlasError(f"region {self.name!r} has neither bounds: nor xy:/size:", source, line=self.line)
        x, y, w, h = got["x"], got["y"], got["w"], got["h"]
        ox, oy, ow, oh, degrees = (got.get(k, 0) for k in ("ox", "oy", "ow", "oh", "degrees"))
        if ow == 0 and oh == 0:  # no original size: the packed one, as the runtimes take it
            ow, oh = w, h
        if w < 0 or h < 0 or ow < 0 or oh < 0:
            raise AtlasError(f"region {self.name!r} has a negative size", source, line=self.line)
        check_image_size(w, h, f"region {self.name!r} size", source, self.line)
        check_image_size(ow, oh, f"region {self.name!r} original size", source, self.line)
        return RegionGeometry(x, y, w, h, ox, oy, ow, oh, degrees)


@dataclass
class AtlasPage(_Fields):
    """A page image and its fields (``size``, ``format``, ``filter``, ``repeat``, ``pma``, ``scale``...)."""

    name: str
    entries: list[Entry] = field(default_factory=list)
    line: int = 0

    @property
    def pma(self) -> bool:
        v = self.get("pma")
        return bool(v) and v[0] == "true"  # as the runtimes compare it: "True" is a straight page there

    @property
    def scale(self) -> float:
        """The export scale of the page: atlas pixels per original image pixel (default 1).

        Checked when the atlas is parsed: a finite number above 0.
        """
        v = self.get("scale")
        return float(v[0]) if v else 1.0

    def validate(self, source) -> None:
        """Raise :class:`AtlasError` (file and line) for a scale that is not a finite number above 0."""
        v = self.get("scale")
        if not v:
            return
        try:
            scale = float(v[0])
        except ValueError:
            scale = math.nan
        if not math.isfinite(scale) or scale <= 0:
            raise AtlasError(f"page {self.name!r}: scale must be a number above 0, found {v[0]!r}",
                             source, line=self.line)
        if not MIN_ATLAS_SCALE <= scale <= MAX_ATLAS_SCALE:
            # the page stands for images 1/scale times its size (see limits.MIN_ATLAS_SCALE)
            raise LimitError(f"page {self.name!r}: scale {v[0]} is outside the limits {MIN_ATLAS_SCALE:g} to "
                             f"{MAX_ATLAS_SCALE:g}", source, line=self.line)


@dataclass(frozen=True)
class PageMismatch:
    """A page whose fields disagree with its image or with another page of the atlas.

    Attributes
    ----------
    page : str
        The page's name (its image file, relative to the atlas).
    line : int
        The page's line in the atlas.
    message : str
        One line naming the page and saying what disagrees.
    runtimes_disagree : bool
        Whether runtimes draw the atlas differently from one another because of it (worth a
        warning wherever the atlas is used); False: harmless to draw, but no page of it may be
        rewritten.
    """

    page: str
    line: int
    message: str
    runtimes_disagree: bool


def page_mismatches(atlas: "Atlas", image_sizes: list[tuple[int, int] | None]) -> list[PageMismatch]:
    """What disagrees between the atlas's pages and their images: the one rule of every command.

    - a ``size:`` line other than the image's size (the image twice or half the size, padded
      larger, or another image): spine-c and the runtimes built on it (cocos2d-x, SFML, Unreal)
      scale UVs by the size line, libGDX and spine-ts 3.x by the texture, so the atlas draws
      differently from one engine to the next;
    - one image named by two pages: each runtime loads it as one texture or as two, so two pages
      of other fields (filter, wrap, format) draw it one way or the other; with the same fields it
      draws alike everywhere, but no page of it can be rewritten on its own.

    Parameters
    ----------
    atlas : Atlas
    image_sizes : list of (int, int) or None
        Per page, its image's ``(width, height)``; None where unknown (not checked).

    Returns
    -------
    list of PageMismatch
        In page order; empty when everything agrees.
    """
    found: list[PageMismatch] = []
    first: dict[str, AtlasPage] = {}
    for page, size in zip(atlas.pages, image_sizes):
        key = as_written(page.name)
        other = first.setdefault(key, page)
        if other is not page:
            same = [e for e in other.entries if e.key != "size"] == [e for e in page.entries if e.key != "size"]
            found.append(PageMismatch(page.name, page.line, (
                f"page {page.name!r} (line {page.line}) names the image of the page at line {other.line} again"
                + ("" if same else ", with other fields (runtimes that share one texture per image draw both "
                   "with one page's)")), not same))
        stated = page.get("size")
        if size is None or stated is None:
            continue
        try:
            w, h = (int(v) for v in stated[:2])
        except ValueError:
            w = h = -1
        if len(stated) < 2 or (w, h) != tuple(size):
            found.append(PageMismatch(page.name, page.line, (
                f"page {page.name!r} (line {page.line}): its size line says {', '.join(stated)} but its image is "
                f"{size[0]}x{size[1]}; spine-c scales UVs by the size line, libGDX by the image, so they draw "
                "it differently"), True))
    return found


@dataclass
class Atlas:
    """A parsed atlas. ``syntax`` is ``"3"`` or ``"4"``; ``path`` is where it was read from."""

    pages: list[AtlasPage]
    regions: list[AtlasRegion]
    syntax: str = "4"
    header: list[Entry] = field(default_factory=list)
    path: Path | None = None
    leading_blank: bool = False
    #: Regions that cannot be used, one line each (only filled by a lenient parse).
    problems: list[str] = field(default_factory=list)
    #: Pages that disagree with their images or with each other (:func:`page_mismatches`), once
    #: the images were looked at (:func:`spinemesh.project.project_atlases`).
    mismatches: list[PageMismatch] = field(default_factory=list)
    #: Per page, its image's ``(width, height)`` from the file's header (None: unreadable), read
    #: once by :func:`spinemesh.project.project_atlases`; empty until then.
    image_sizes: list[tuple[int, int] | None] = field(default_factory=list)

    def find(self, name: str) -> AtlasRegion | None:
        """The first region called ``name``, as the runtimes' ``findRegion`` returns it."""
        if not hasattr(self, "_by_name"):
            self._by_name: dict[str, AtlasRegion] = {}
            for r in self.regions:
                self._by_name.setdefault(r.name, r)
        return self._by_name.get(name)

    def page_path(self, region_or_page: AtlasRegion | AtlasPage) -> str:
        page = region_or_page if isinstance(region_or_page, AtlasPage) else self.pages[region_or_page.page]
        return page.name

    def dumps(self) -> str:
        """The atlas as text in its own syntax."""
        out: list[str] = []
        if self.leading_blank:
            out.append("")
        out.extend(e.line() for e in self.header)
        by_page: dict[int, list[AtlasRegion]] = {}
        for r in self.regions:
            by_page.setdefault(r.page, []).append(r)
        for i, page in enumerate(self.pages):
            if i > 0 or self.header:
                out.append("")
            out.append(page.name)
            out.extend(e.line() for e in page.entries)
            for r in by_page.get(i, []):
                out.append(r.name)
                out.extend(e.line() for e in r.entries)
        return "\n".join(out) + "\n"

    def model(self) -> dict:
        """A plain, comparable view of the atlas: pages and regions with their fields."""
        return {
            "syntax": self.syntax,
            "header": [(e.key, e.values) for e in self.header],
            "pages": [(p.name, [(e.key, e.values) for e in p.entries]) for p in self.pages],
            "regions": [(r.name, r.page, [(e.key, e.values) for e in r.entries]) for r in self.regions],
        }


#: The geometry fields of a region line and what each sets, in order.
_GEOMETRY_FIELDS = {"bounds": ("x", "y", "w", "h"), "xy": ("x", "y"), "size": ("w", "h"),
                    "offsets": ("ox", "oy", "ow", "oh"), "offset": ("ox", "oy"), "orig": ("ow", "oh")}


def _degrees(region, values: list[str], source) -> int:
    """A ``rotate:`` line's degrees: ``true`` 90, ``false`` 0, else 0, 90, 180 or 270."""
    # compared exactly, as the 4.x runtimes do: "True" is no turn there (spine-ts parses it as a
    # number, NaN: drawn unturned; libGDX fails to load), where read case-blind it was 90 degrees
    r = values[0].strip() if values else "false"
    if r in ("true", "false"):
        return 90 if r == "true" else 0
    try:
        degrees = int(r)
    except ValueError:
        raise AtlasError(f"region {region.name!r}: rotate must be true, false or degrees, found {r!r}",
                         source, line=region.line) from None
    # The runtimes turn a region by exactly 90, 180 or 270 and draw any other number
    # (-90, 450) unturned: read modulo 360, such a region was cut and packed turned.
    if degrees not in _TURNS:
        raise AtlasError(f"region {region.name!r}: rotate must be 0, 90, 180 or 270, found {r} "
                         "(the Spine runtimes draw it unturned)", source, line=region.line)
    return degrees


def _ints(item, key: str, values: list[str], n: int, source) -> list[int]:
    """The first ``n`` whole numbers of ``values``, ``item``'s ``key`` line."""
    if len(values) < n:
        raise AtlasError(f"{item.name!r}: {key}: needs {n} numbers, found {len(values)}", source, line=item.line)
    try:
        return [int(v) for v in values[:n]]
    except ValueError:
        raise AtlasError(f"{item.name!r}: {key}: expected whole numbers, found {', '.join(values)!r}",
                         source, line=item.line) from None


def _entry(raw: str) -> Entry | None:
    """Parse ``key: a, b`` (or ``None`` for a line without a colon, i.e. a name)."""
    stripped = raw.strip()
    colon = stripped.find(":")
    if colon < 0:
        return None
    key = stripped[:colon].strip()
    after = stripped[colon + 1:]
    rest = after.strip()
    colon_text = stripped[len(stripped[:colon].rstrip()):colon + 1 + len(after) - len(after.lstrip())]
    values = [v.strip() for v in rest.split(",")] if rest else []
    sep = ", " if ", " in rest else ","
    indent = raw[: len(raw) - len(raw.lstrip())]
    # the same few keys and spacings on every line: one string each, not one per line
    return Entry(_shared(key), values, _shared(indent), sep, _shared(colon_text))


def _shared(text: str) -> str:
    return sys.intern(text) if len(text) < 32 else text


def parse_atlas(text: str, source: str | Path | None = None, strict: bool = True) -> Atlas:
    """Parse atlas text of either syntax.

    The structure follows the runtimes' reader: a blank line ends a page, the next name
    starts a page, and any other name starts a region of the current page. Names may
    contain colons only in the sense that a line with a colon is always an entry.

    Parameters
    ----------
    strict : bool
        True: a region with malformed geometry fails the whole atlas. False: the region
        keeps its error (raised when it is used) and ``atlas.problems`` lists it, so one bad
        region only fails the attachments that draw it.

    Raises
    ------
    AtlasError
        With the line number, for an entry before any name, a file with no pages, a page
        scale that is not a number above 0, or (``strict``) a malformed region.
    """
    # A region takes at most about ten lines (name, bounds or xy and size, orig, offset(s),
    # rotate, index, split, pad): refused by its line count before anything is parsed.
    line_count = text.count("\n") + text.count("\r") - text.count("\r\n")
    if line_count > 10 * MAX_ATLAS_REGIONS:
        raise LimitError(f"{line_count:,} lines: more than the {MAX_ATLAS_REGIONS:,} regions an atlas may hold",
                         source)
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    if text.startswith("\ufeff"):
        lines[0] = lines[0][1:]
    atlas = Atlas(pages=[], regions=[], path=Path(source) if source else None)
    i = 0
    while i < len(lines) and not lines[i].strip():
        atlas.leading_blank = True
        i += 1
    # Header entries before the first page name (rare; the runtimes ignore them).
    while i < len(lines) and lines[i].strip() and _entry(lines[i]) is not None:
        atlas.header.append(_entry(lines[i]))
        i += 1
    page: AtlasPage | None = None
    current: AtlasPage | AtlasRegion | None = None
    for n in range(i, len(lines)):
        raw = lines[n]
        if not raw.strip():
            page = current = None
            continue
        entry = _entry(raw)
        if entry is not None:
            if current is None:
                raise AtlasError(f"entry {entry.key!r} does not belong to any page or region", source, line=n + 1)
            current.entries.append(entry)
            continue
        name = raw.strip()
        if page is None:
            page = AtlasPage(name=name, line=n + 1)
            atlas.pages.append(page)
            current = page
        else:
            if len(atlas.regions) >= MAX_ATLAS_REGIONS:
                raise LimitError(f"more than {MAX_ATLAS_REGIONS:,} regions, the limit of one atlas", source,
                                 line=n + 1)
            region = AtlasRegion(name=name, page=len(atlas.pages) - 1, line=n + 1)
            atlas.regions.append(region)
            current = region
    if not atlas.pages:
        raise AtlasError("no atlas pages found (empty or not an atlas)", source)
    keys = {e.key for r in atlas.regions for e in r.entries} | {e.key for p in atlas.pages for e in p.entries}
    atlas.syntax = "4" if keys & _V4_KEYS or "xy" not in keys and atlas.regions else "3"
    where = str(source) if source else None
    for p in atlas.pages:
        p.validate(where)
    for r in atlas.regions:
        try:
            r.geometry(where)  # validate numbers now, with line numbers
        except SpineMeshError as e:
            if strict:
                raise
            r.error = e
            atlas.problems.append(str(e))
    return atlas


def read_atlas(path: str | Path, strict: bool = True) -> Atlas:
    """Read an atlas file (``.atlas``, ``.atlas.txt``...). Raises :class:`AtlasError`.

    Parameters
    ----------
    path : path
        The atlas file, in the 3.x (``xy:``/``size:``) or 4.x (``bounds:``) syntax; its size is
        bounded (:mod:`spinemesh.limits`).
    strict : bool, default True
        See :func:`parse_atlas`: false lists unusable regions in ``problems`` instead of
        refusing the file.

    Returns
    -------
    Atlas
        Its pages and regions in file order, every entry kept so that :meth:`Atlas.dumps`
        gives back the same text.

    Examples
    --------
    >>> from spinemesh.demo import make_demo_project
    >>> atlas = read_atlas(make_demo_project("demo") / "demo.atlas")
    >>> atlas.syntax, [page.name for page in atlas.pages], [r.name for r in atlas.regions][:2]
    ('4', ['demo.png'], ['demo-body', 'demo-head'])
    """
    path = Path(path)
    try:
        check_file_size(path, "atlas")
        raw = path.read_bytes()
    except OSError as e:
        raise AtlasError(f"cannot read atlas: {e.strerror}", path) from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        raise AtlasError(f"atlas is not UTF-8 text (byte {e.start})", path) from None
    return parse_atlas(text, path, strict)
