"""Original-size images of attachments, from atlas pages or from a plain images folder.

An atlas stores each image trimmed of transparent borders, possibly rotated, possibly
premultiplied and possibly scaled. :class:`AtlasImages` undoes all of that except the
scale: it returns the image at its original size *in atlas pixels* and reports the page
scale, so that ``skeleton units = atlas pixels / scale``.

:class:`FolderImages` reads the unpacked images the Spine editor works from
(``images/<path>.png``), so a skeleton can be processed without any atlas.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image

from .atlas import Atlas, AtlasRegion, read_atlas
from .errors import AtlasError, ImageError
from .fsutil import resolve_inside

#: Image file extensions looked for in an images folder, in order of preference.
IMAGE_EXTENSIONS = (".png", ".webp", ".avif", ".jpg", ".jpeg")


@dataclass
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
    """

    rgba: np.ndarray
    scale: float
    name: str
    source: str
    content: tuple[int, int, int, int] | None = None

    def __post_init__(self):
        if self.content is None:
            h, w = self.rgba.shape[:2]
            self.content = (0, 0, w, h)


def load_rgba(path: str | Path) -> np.ndarray:
    """Decode a PNG, WebP, AVIF or JPEG file to an (H, W, 4) uint8 RGBA array."""
    try:
        with Image.open(path) as im:
            im.load()
            if im.mode != "RGBA":
                im = im.convert("RGBA")
            return np.asarray(im, dtype=np.uint8).copy()
    except FileNotFoundError:
        raise ImageError("image file not found", path) from None
    except (OSError, ValueError, Image.DecompressionBombError) as e:
        raise ImageError(f"cannot decode image: {e}", path) from None


def unpremultiply(rgba: np.ndarray) -> np.ndarray:
    """Straight-alpha RGBA from premultiplied RGBA (uint8 in, uint8 out).

    Colour channels are divided by alpha with rounding; fully transparent pixels become
    black. At low alpha the division cannot be exact in 8 bits; premultiplying the result
    again gives back the input within 1 per channel.
    """
    a = rgba[..., 3:4].astype(np.uint32)
    rgb = rgba[..., :3].astype(np.uint32)
    safe = np.maximum(a, 1)
    straight = np.minimum((rgb * 255 + safe // 2) // safe, 255)
    straight = np.where(a > 0, straight, 0)
    out = rgba.copy()
    out[..., :3] = straight.astype(np.uint8)
    return out


def premultiply(rgba: np.ndarray) -> np.ndarray:
    """Premultiplied RGBA from straight RGBA, rounding to nearest (uint8 in, uint8 out)."""
    a = rgba[..., 3:4].astype(np.uint32)
    out = rgba.copy()
    out[..., :3] = ((rgba[..., :3].astype(np.uint32) * a + 127) // 255).astype(np.uint8)
    return out


def cut_region(page: np.ndarray, region: AtlasRegion, pma: bool = False,
               source: str | None = None) -> np.ndarray:
    """Cut one region out of a page image and restore its original size and orientation.

    Parameters
    ----------
    page : ndarray, shape (PH, PW, 4), uint8
        The page image as stored.
    region : AtlasRegion
        The region; its geometry is in page pixels.
    pma : bool
        Whether the page is premultiplied; the result is always straight alpha.

    Returns
    -------
    ndarray, shape (original_height, original_width, 4), uint8
    """
    g = region.geometry(source)
    ph, pw = page.shape[:2]
    if g.x < 0 or g.y < 0 or g.x + g.page_width > pw or g.y + g.page_height > ph:
        raise AtlasError(f"region {region.name!r} ({g.x}, {g.y}, {g.page_width}x{g.page_height}) "
                         f"lies outside its {pw}x{ph} page", source, line=region.line)
    crop = page[g.y:g.y + g.page_height, g.x:g.x + g.page_width]
    if g.degrees:
        # Packers store the image turned counter-clockwise; turning it clockwise undoes that.
        crop = np.rot90(crop, -(g.degrees // 90))
    if pma:
        crop = unpremultiply(crop)
    top = g.original_height - g.offset_y - g.height
    left = g.offset_x
    if top < 0 or left < 0 or left + g.width > g.original_width or top + g.height > g.original_height:
        raise AtlasError(f"region {region.name!r}: offsets place the image outside its original "
                         f"{g.original_width}x{g.original_height} size", source, line=region.line)
    out = np.zeros((g.original_height, g.original_width, 4), np.uint8)
    out[top:top + g.height, left:left + g.width] = crop
    return out


class AtlasImages:
    """Region images from one or more atlases, with a small cache of decoded pages.

    Parameters
    ----------
    atlases : list of Atlas
        Parsed atlases, each with its ``path`` set; earlier atlases win on duplicate names.
    root : path, optional
        Folder that page files may not leave (default: each atlas's own folder).
    cache_pages : int
        How many decoded pages to keep in memory (pages can be 64 MB each).
    """

    def __init__(self, atlases: list[Atlas], root: str | Path | None = None, cache_pages: int = 2):
        self.atlases = atlases
        self.root = Path(root) if root else None
        self._pages: OrderedDict[Path, np.ndarray] = OrderedDict()
        self._cache_pages = cache_pages
        self._index: dict[str, tuple[Atlas, AtlasRegion]] = {}
        for atlas in atlases:
            for region in atlas.regions:
                self._index.setdefault(region.name, (atlas, region))

    @classmethod
    def from_files(cls, paths: list[str | Path], root: str | Path | None = None) -> "AtlasImages":
        return cls([read_atlas(p) for p in paths], root)

    def __contains__(self, name: str) -> bool:
        return name in self._index

    def names(self) -> list[str]:
        return list(self._index)

    def page_file(self, atlas: Atlas, page_index: int) -> Path:
        """The page image path, refusing names that leave the project (``../``)."""
        assert atlas.path is not None
        page = atlas.pages[page_index]
        root = self.root or atlas.path.parent
        rel_dir = atlas.path.parent.resolve().relative_to(Path(root).resolve())
        return resolve_inside(root, str(rel_dir / page.name), atlas.path)

    def _page(self, path: Path) -> np.ndarray:
        if path in self._pages:
            self._pages.move_to_end(path)
            return self._pages[path]
        pixels = load_rgba(path)
        self._pages[path] = pixels
        while len(self._pages) > self._cache_pages:
            self._pages.popitem(last=False)
        return pixels

    def get(self, name: str) -> RegionImage:
        """The original-size image of region ``name``. Raises :class:`ImageError` if absent."""
        found = self._index.get(name)
        if found is None:
            raise ImageError(f"no atlas region named {name!r}", self.atlases[0].path if self.atlases else None)
        atlas, region = found
        page_path = self.page_file(atlas, region.page)
        page = atlas.pages[region.page]
        rgba = cut_region(self._page(page_path), region, page.pma, str(atlas.path))
        g = region.geometry(str(atlas.path))
        top = g.original_height - g.offset_y - g.height
        content = (g.offset_x, top, g.offset_x + g.width, top + g.height)
        return RegionImage(rgba, page.scale, name, str(page_path), content)


class FolderImages:
    """Images from a folder laid out as the Spine editor's images folder.

    ``get("eyes/blink")`` reads ``<folder>/eyes/blink.png`` (or ``.webp``, ``.avif``,
    ``.jpg``). Scale is 1: editor images are at skeleton size.
    """

    def __init__(self, folder: str | Path):
        self.folder = Path(folder)

    def path_of(self, name: str) -> Path | None:
        for ext in IMAGE_EXTENSIONS:
            p = resolve_inside(self.folder, name + ext)
            if p.is_file():
                return p
        return None

    def __contains__(self, name: str) -> bool:
        return self.path_of(name) is not None

    def names(self) -> list[str]:
        out = []
        for p in sorted(self.folder.rglob("*")):
            if p.suffix.lower() in IMAGE_EXTENSIONS and p.is_file():
                out.append(p.relative_to(self.folder).with_suffix("").as_posix())
        return out

    def get(self, name: str) -> RegionImage:
        p = self.path_of(name)
        if p is None:
            raise ImageError(f"no image {name!r} (looked for {', '.join(name + e for e in IMAGE_EXTENSIONS)})",
                             self.folder)
        return RegionImage(load_rgba(p), 1.0, name, str(p))
