"""The images of attachments: :class:`RegionImage`, and the two sources that give them,
:class:`AtlasImages` (regions cut from atlas pages) and :class:`FolderImages` (the editor's
images folder).

What the rest of the package asks for an attachment's image; the decoding, the texels, the
cutting and the page cache are the modules below it (:mod:`.decode`, :mod:`.texels`,
:mod:`.regions`, :mod:`.pages`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..atlas import Atlas, AtlasRegion, read_atlas
from ..errors import ImageError, UnsafePathError
from ..files.inside import resolve_inside
from ..files.names import portable_name
from ..files.walk import walk_files
from ..foreground import alpha_above, texels_as_words
from . import decode
from .decode import IMAGE_EXTENSIONS
from .pages import PageStore
from .regions import _bleeding_border, placed, stored_rectangle, upright_part
from .texels import FAINT_TEXEL, shown_texels, unpremultiply


class RegionImage:
    """An attachment image at its original size.

    Attributes
    ----------
    rgba : ndarray, shape (H, W, 4), uint8
        Straight (not premultiplied) RGBA, with stripped whitespace restored.
    scale : float
        Image pixels per skeleton unit (the atlas page's ``scale:``; 1 for image folders).
    name : str
        The region or image path it was looked up by.
    source : str
        The file the pixels came from (page image or image file).
    content : tuple of int
        ``(x0, y0, x1, y1)``: the part of the original image that the atlas actually stores
        (the rest was stripped whitespace). Anything drawn outside it samples whatever lies
        next to the region on the page. The whole image for an images folder.
    drawn : ndarray, shape (H, W), bool
        Texels a runtime draws anything with: alpha > 0, or on a premultiplied page any
        channel > 0 (a premultiplied texel with alpha 0 and colour > 0 is light that adds to
        whatever lies below it, in normal and additive blending alike; straight alpha cannot
        hold it, so ``rgba`` shows it as transparent); from an atlas, also the border texels
        next to drawn texels just outside the stored rectangle on the page, which the quad's
        edge samples (:func:`.regions.bleeding_in`). Default: ``alpha > 0``.
    shown : ndarray, shape (H, W), bool
        The part of ``drawn`` that can change a pixel by more than :data:`FAINT_TEXEL`/255
        when drawn with normal blending (:func:`shown_texels`); the bleed-in border texels
        always. Default: ``alpha > FAINT_TEXEL``.

    ``drawn`` and ``shown`` are computed on first use when not given: a data set, which
    stores texels only, never pays for them.
    """

    def __init__(self, rgba: np.ndarray, scale: float, name: str, source: str,
                 content: tuple[int, int, int, int] | None = None, drawn: np.ndarray | None = None,
                 shown: np.ndarray | None = None):
        self._rgba, self.scale, self.name, self.source = rgba, scale, name, source
        self.shape = rgba.shape
        self.content = (0, 0, rgba.shape[1], rgba.shape[0]) if content is None else content
        self._drawn, self._shown = drawn, shown
        #: ``(rgba, drawn, shown)`` of the stored part alone (:meth:`from_stored`), else None
        self.stored: tuple | None = None

    @classmethod
    def from_stored(cls, rgba: np.ndarray, shape: tuple[int, ...], content: tuple[int, int, int, int], scale: float,
                    name: str, source: str, drawn: np.ndarray | None = None,
                    shown: np.ndarray | None = None) -> "RegionImage":
        """An image of ``shape`` (H, W, 4) that is zero outside ``content``, given by its part
        inside it: ``rgba`` (h, w, 4), ``drawn`` and ``shown`` (h, w) bool, the stored part
        of each. The whole-size arrays are made when first asked for (:meth:`place`): the
        planning of an upgrade meshes the stored part alone and never needs them.
        """
        image = cls(rgba, scale, name, source, content)
        image._rgba, image.shape = None, tuple(shape)
        image.stored = (rgba, drawn, shown)
        return image

    def place(self, part: np.ndarray) -> np.ndarray:
        """``part`` (the stored part's values, (h, w, ...)) at the original size, zero elsewhere;
        ``part`` itself when the stored part is the whole image."""
        return placed(part, self.shape[:2], self.content)

    @property
    def rgba(self) -> np.ndarray:
        if self._rgba is None:
            self._rgba = self.place(self.stored[0])
        return self._rgba

    @property
    def drawn(self) -> np.ndarray:
        if self._drawn is None:
            self._drawn = self.place(self.stored_masks()[0]) if self.stored else alpha_above(self.rgba, 0)
        return self._drawn

    @property
    def shown(self) -> np.ndarray:
        if self._shown is None:
            self._shown = self.place(self.stored_masks()[1]) if self.stored \
                else self.drawn & alpha_above(self.rgba, FAINT_TEXEL)
        return self._shown

    def stored_masks(self) -> tuple[np.ndarray, np.ndarray]:
        """``drawn`` and ``shown`` of the stored part alone, (h, w) bool each (:meth:`from_stored`
        images only), with the same defaults as the whole image's."""
        return self.stored_mask(shown=False), self.stored_mask(shown=True)

    def stored_mask(self, shown: bool) -> np.ndarray:
        """``shown`` (True) or ``drawn`` (False) of the stored part alone (:meth:`stored_masks`).

        A default is worked out when first asked for, then kept: a caller that needs one of
        the two masks (meshing for one blend mode) does not pay for the other.
        """
        rgba, drawn, shown_mask = self.stored
        if not shown:
            if drawn is None:
                drawn = alpha_above(rgba, 0)
                self.stored = (rgba, drawn, shown_mask)
            return drawn
        if shown_mask is None:
            # drawn & (alpha > FAINT_TEXEL); the default drawn (alpha > 0) holds every such texel
            faint = alpha_above(rgba, FAINT_TEXEL)
            shown_mask = faint if drawn is None else drawn & faint
            self.stored = (rgba, drawn, shown_mask)
        return shown_mask


class AtlasImages:
    """Region images from one or more atlases, cut from pages decoded once (:class:`PageStore`).

    Parameters
    ----------
    atlases : list of Atlas
        Parsed atlases, each with its ``path`` set; earlier atlases win on duplicate names.
    root : path, optional
        Folder that page files may not leave (default: each atlas's own folder).
    cache_pages : int, optional
        Without ``pages``: how many decoded pages this source keeps (pages can be 64 MB each);
        default: as many as :data:`spinemesh.limits.MAX_PAGE_STORE_BYTES` holds.
    pages : PageStore, optional
        The store to decode pages through, shared with other sources of the same project
        (:func:`spinemesh.project.project_pages`); default: one of this source's own.
    """

    def __init__(self, atlases: list[Atlas], root: str | Path | None = None, cache_pages: int | None = None,
                 pages: PageStore | None = None):
        self.atlases = atlases
        self.root = Path(root) if root else None
        self.pages = pages if pages is not None else PageStore(max_pages=cache_pages)
        self._page_files: dict[tuple[int, int], Path] = {}
        self._index: dict[str, tuple[Atlas, AtlasRegion]] = {}
        for atlas in atlases:
            for region in atlas.regions:
                self._index.setdefault(region.name, (atlas, region))
        #: portable name (:func:`..files.names.portable_name`) -> region names of that name, once a name missed
        self._portable: dict[str, list[str]] | None = None

    @classmethod
    def from_files(cls, paths: list[str | Path], root: str | Path | None = None) -> "AtlasImages":
        return cls([read_atlas(p) for p in paths], root)

    def __contains__(self, name: str) -> bool:
        return name in self._index

    def names(self) -> list[str]:
        return list(self._index)

    @staticmethod
    def page_path(atlas: Atlas, page_name: str, root: str | Path | None = None) -> Path:
        """The real path of a page image named in ``atlas``, refusing names that leave ``root``.

        Raises
        ------
        UnsafePathError
            If the page name climbs out of ``root`` (default: the atlas's folder), also through
            a symlink.
        """
        assert atlas.path is not None
        root = Path(root) if root is not None else atlas.path.parent
        try:
            rel_dir = atlas.path.parent.resolve().relative_to(root.resolve())
        except ValueError:
            raise UnsafePathError("atlas lies outside the project folder", atlas.path) from None
        return resolve_inside(root, f"{rel_dir.as_posix()}/{page_name}", atlas.path)

    def page_files(self, names) -> list[Path]:
        """The page files the regions ``names`` lie on, each once, in the order first named.

        Names no atlas holds and pages whose path is refused are left out: :meth:`get` reports
        those when asked.
        """
        out: dict[Path, None] = {}
        for name in names:
            found = self._index.get(name)
            if found is not None and 0 <= found[1].page < len(found[0].pages):
                try:
                    out[self.page_file(found[0], found[1].page)] = None
                except UnsafePathError:
                    continue
        return list(out)

    def page_file(self, atlas: Atlas, page_index: int) -> Path:
        """The page image path, refusing names that leave the project (``../``).

        Resolved once per page (real paths cost a system call per folder), then remembered.
        """
        key = (id(atlas), page_index)
        found = self._page_files.get(key)
        if found is None:
            found = self._page_files[key] = self.page_path(atlas, atlas.pages[page_index].name, self.root)
        return found

    def _alike(self, name: str) -> str:
        """For a name no region has: the regions named so but for case or Unicode form (a project
        moved between macOS, Windows and Linux), which runtimes do not match either; or ``""``."""
        if self._portable is None:
            self._portable = {}
            for other in self._index:
                self._portable.setdefault(portable_name(other), []).append(other)
        alike = self._portable.get(portable_name(name), [])
        if not alike:
            return ""
        return (f"; the atlas has {', '.join(map(repr, alike[:3]))}, other in case or Unicode form only, which "
                "runtimes do not match either")

    def get(self, name: str, coverage: bool = True) -> RegionImage:
        """The original-size image of region ``name``. Raises :class:`ImageError` if absent.

        ``coverage=False`` (a data set, which stores texels only) leaves out what the page
        adds to :attr:`RegionImage.drawn` and :attr:`RegionImage.shown` (premultiplied
        light, the bleed-in border): they are then the alpha defaults, as from an images folder.
        """
        found = self._index.get(name)
        if found is None:
            raise ImageError(f"no atlas region named {name!r}{self._alike(name)}",
                             self.atlases[0].path if self.atlases else None)
        atlas, region = found
        page_path = self.page_file(atlas, region.page)
        page = atlas.pages[region.page]
        pixels = self.pages.page(page_path)
        # Everything per texel is worked out on the stored rectangle, then placed upright at
        # the original size: stripped whitespace is zero either way, and an original size
        # may be many times the rectangle (a 1999x3553 shadow stored as 1987x202).
        # Placing it at the original size waits until something asks for the whole image
        # (RegionImage.from_stored): the planning of an upgrade needs the stored part alone.
        source = str(atlas.path)
        g = region.geometry(source)
        stored = stored_rectangle(pixels, region, source, g)
        rgba, (height, width), content = upright_part(unpremultiply(stored) if page.pma else stored, region,
                                                      source, g)
        shape = (height, width, 4)
        if not coverage:
            return RegionImage.from_stored(rgba, shape, content, page.scale, name, str(page_path))
        bleed = _bleeding_border(pixels, g, page.pma)
        if bleed is None and not page.pma:
            # The defaults of from_stored are these masks exactly (alpha > 0, alpha > FAINT_TEXEL
            # of the straight texels): worked out only if asked for, on the upright part.
            return RegionImage.from_stored(rgba, shape, content, page.scale, name, str(page_path))
        drawn = texels_as_words(stored) != 0 if page.pma else alpha_above(stored, 0)
        shown = shown_texels(stored, page.pma)
        if bleed is not None:  # most regions have none: no pass over either mask then
            drawn |= bleed
            shown |= bleed
        drawn = upright_part(drawn, region, source, g)[0]
        shown = upright_part(shown, region, source, g)[0]
        return RegionImage.from_stored(rgba, shape, content, page.scale, name, str(page_path), drawn, shown)


class FolderImages:
    """Images from a folder laid out as the Spine editor's images folder.

    ``get("eyes/blink")`` reads ``<folder>/eyes/blink.png`` (or ``.webp``, ``.avif``,
    ``.jpg``). Scale is 1: editor images are at skeleton size. A name found under no spelling of
    its own is the one image that is that file on a macOS or Windows disk, where the editor that
    exported the skeleton found it: ``Hero`` for ``hero.png``, ``head`` for ``head.PNG``, ``café``
    written in the other Unicode form (macOS writes NFD); none when several are.
    """

    def __init__(self, folder: str | Path):
        self.folder = Path(folder)
        #: portable name (:func:`..files.names.portable_name`) -> images of that name, once a name missed
        self._portable: dict[str, list[Path]] | None = None

    def path_of(self, name: str) -> Path | None:
        for ext in IMAGE_EXTENSIONS:
            p = resolve_inside(self.folder, name + ext)
            if p.is_file():
                return p
        if self._portable is None:
            self._portable = {}
            for p in self._files():
                self._portable.setdefault(portable_name(self._name(p)), []).append(p)
        found = self._portable.get(portable_name(name), [])
        return found[0] if len(found) == 1 else None

    def _files(self) -> list[Path]:
        if not self.folder.is_dir():
            return []
        return [p for p in walk_files(self.folder) if p.suffix.lower() in IMAGE_EXTENSIONS]

    def _name(self, path: Path) -> str:
        return path.relative_to(self.folder).with_suffix("").as_posix()

    def __contains__(self, name: str) -> bool:
        return self.path_of(name) is not None

    def names(self) -> list[str]:
        return [self._name(p) for p in self._files()]

    def get(self, name: str, coverage: bool = True) -> RegionImage:
        """The image ``name`` at its size; ``coverage`` is for :meth:`AtlasImages.get`'s sake (same here)."""
        p = self.path_of(name)
        if p is None:
            alike = [q.relative_to(self.folder).as_posix() for q in (self._portable or {}).get(portable_name(name), [])]
            if alike:  # several: the editor's disk held one of them, which one is unknown here
                raise ImageError(f"no image {name!r}; {', '.join(alike[:4])} are each that file on a macOS or "
                                 "Windows disk (case, Unicode form), so which one is meant is unknown", self.folder)
            raise ImageError(f"no image {name!r} (looked for {', '.join(name + e for e in IMAGE_EXTENSIONS)})",
                             self.folder)
        return RegionImage(decode.load_rgba(p), 1.0, name, str(p))
