"""The data set on disk: tar shards of PNGs and one JSONL index, read by :func:`open_dataset`.

Layout of a data set folder ``DS``::

    DS/meta.json         format name and version, mask threshold, validation fraction
    DS/index.jsonl       one JSON object per sample (a "row"), see below
    DS/projects.jsonl    one JSON object per processed project: name, game, counts, errors
    DS/shards/*.tar      plain (uncompressed) tar files holding, per sample ``<id>``:
                           <id>.png       the RGBA image, cropped to ``box``
                           <id>.mask.png  its mask (alpha > 128), 1-bit PNG, cropped alike
                           <id>.mesh.npz  artist mesh, for mesh samples only (numpy .npz)

A row holds ``id`` (128-bit content hash of the image, hex), ``project``, ``game``,
``version`` (Spine editor version), ``split`` (``"train"`` or ``"val"``), ``type``
(``"region"`` or ``"mesh"``), ``attachment`` (the skeleton's own type: region, mesh or
linkedmesh), ``name`` (image path), ``skeleton`` (file, relative to the project), ``ref``
(``[skin, slot, attachment name]`` of the first attachment drawing it), ``source`` (the
atlas file or images folder it was cut from, relative to the project), ``width``,
``height`` (pixels), ``scale`` (atlas page scale: image pixels per skeleton unit),
``n_vertices``, ``n_triangles`` (0 for regions), ``box`` ``[x, y, w, h]``: the smallest
rectangle holding every non-zero pixel (outside it the image is all zeros; atlas images
are often mostly empty, and PNG-encoding only the box is ~7x faster), ``shard`` (path
relative to ``DS``) and
``image``, ``mask``, ``mesh``: ``[byte offset, byte size]`` of that member's data inside the
shard (``mesh`` is ``null`` for regions). So any sample is one ``pread`` away, and the
index can be streamed line by line; nothing needs to be unpacked.

The mesh ``.npz`` holds ``vertices`` (N, 2) float32 pixel positions (UV times image size, x
right, y down), ``triangles`` (T, 3) int32 vertex indices, ``hull`` (H,) int32 indices of
the outline vertices in order (Spine puts them first), ``edges`` (E, 2) int32 vertex-index
pairs of the artist's extra edges (may be empty).

Crash safety: a shard is written to a temporary file and renamed into place before any
row points into it; rows and project lines are appended with one write each and synced.
A run killed mid-append leaves at most one torn last line, which readers ignore and the
next run cuts off before appending (:func:`repair_tail`).
"""

from __future__ import annotations

import io
import json
import os
import tarfile
from collections import OrderedDict
from pathlib import Path
from typing import Iterator

import cv2
import numpy as np

from ..errors import ImageError, LimitError, SpineMeshError
from ..files.atomic import atomic_write_stream
from ..files.inputs import regular_file
from ..files.inside import resolve_inside
from ..files.names import name_as_text
from ..foreground import ALPHA_THRESHOLD, alpha_mask, texels_as_words
from ..images.decode import decode_rgba
from ..limits import MAX_IMAGE_PIXELS, check_image_size
from ..skeleton_check import is_int

FORMAT = "spinemesh-dataset"
FORMAT_VERSION = 1
#: Mask threshold of the paper (sec. 3, "Alpha Channel Path": tau_alpha = 128).
MASK_ALPHA_THRESHOLD = ALPHA_THRESHOLD
#: Share of games held out for validation (paper sec. 4, "Dataset Statistics": 90/10).
VAL_FRACTION = 0.10

INDEX = "index.jsonl"
PROJECTS = "projects.jsonl"
META = "meta.json"
SHARDS = "shards"

#: Largest member of a shard a row may point at: the PNG of the largest image, 4 bytes a texel
#: and a row's filter byte, uncompressed, with room for its chunks (a mesh's .npz is far smaller).
MAX_MEMBER_BYTES = 5 * MAX_IMAGE_PIXELS + (1 << 20)


def checked_row(row, root: Path, index: Path, line: int, shards: dict[str, Path]) -> dict:
    """An index row as the readers use it, or one line naming the index and its line.

    What a row says is bounded and kept inside the data set before anything is read by it: its
    shard a path inside ``root`` (an index naming ``/etc/passwd`` or ``../..`` was read there),
    its sizes within the image limits and its box inside them (a width of 100000 asked for tens
    of gigabytes), its members' ``[offset, size]`` counts of bytes below
    :data:`MAX_MEMBER_BYTES`; a field missing or of another type was a traceback.

    Parameters
    ----------
    row : object
        One parsed line of ``index.jsonl``.
    root, index : Path
        The data set folder and its index file.
    line : int
        1-based line number of the row.
    shards : dict
        Shard paths as written -> real path, checked once each (filled here).

    Raises
    ------
    SpineMeshError
        Naming ``index`` and ``line``.
    """
    def bad(what: str) -> SpineMeshError:
        return SpineMeshError(f"index row of another form: {what}", index, line=line)

    if not isinstance(row, dict):
        raise bad(f"a JSON {type(row).__name__}, not an object")
    for key in ("id", "project", "game", "shard"):
        if not isinstance(row.get(key), str):
            raise bad(f"{key} is {row.get(key)!r}, not text")
    if row.get("split") not in ("train", "val"):
        raise bad(f"split is {row.get('split')!r}, not 'train' or 'val'")
    width, height, box = row.get("width"), row.get("height"), row.get("box")
    if not (is_int(width) and is_int(height) and width > 0 and height > 0):
        raise bad(f"width and height are {width!r} and {height!r}, not sizes in pixels")
    check_image_size(width, height, f"sample {row['id']!r}", index, line=line)
    if not (isinstance(box, list) and len(box) == 4 and all(map(is_int, box))) \
            or box[0] < 0 or box[1] < 0 or box[2] < 1 or box[3] < 1 \
            or box[0] + box[2] > width or box[1] + box[3] > height:
        raise bad(f"box is {box!r}, not [x, y, w, h] inside its {width}x{height} image")
    for member in ("image", "mask", "mesh"):
        span = row.get(member)
        if member == "mesh" and not span:
            continue
        if not (isinstance(span, list) and len(span) == 2 and all(map(is_int, span))) \
                or span[0] < 0 or not 0 <= span[1] <= MAX_MEMBER_BYTES:
            raise bad(f"{member} is {span!r}, not [offset, size] of at most {MAX_MEMBER_BYTES:,} bytes")
    shard = row["shard"]
    if shard not in shards:
        shards[shard] = _shard_path(root, shard, index)
    return row


def _shard_path(root: Path, shard: str, index: Path) -> Path:
    """The real path of a shard a row names: inside the data set, a regular file (opened, a FIFO
    there waited for ever)."""
    path = resolve_inside(root, shard, index, what="data set folder")
    if path.exists():  # a missing shard is said when a member is read, by its sample
        regular_file(path, "shard")
    return path


def mask_of(rgba: np.ndarray) -> np.ndarray:
    """The paper's binary mask: alpha > 128 (sec. 3). (H, W, 4) uint8 -> (H, W) bool."""
    return alpha_mask(rgba, MASK_ALPHA_THRESHOLD)


def tight_box(rgba: np.ndarray) -> tuple[int, int, int, int]:
    """``(x, y, w, h)``: the smallest rectangle holding every pixel that is not all zeros.

    At least 1x1, so that an empty image still has something to store.
    """
    nonzero = texels_as_words(rgba) != 0  # also for a view of a page, without copying it first
    x, y, w, h = cv2.boundingRect(nonzero.view(np.uint8))
    return int(x), int(y), max(int(w), 1), max(int(h), 1)


def crop(image: np.ndarray, box) -> np.ndarray:
    x, y, w, h = box
    return image[y:y + h, x:x + w]


def uncrop(part: np.ndarray, box, width: int, height: int) -> np.ndarray:
    """Place a cropped array back at ``box`` in a zero array of the full size."""
    x, y, w, h = box
    out = np.zeros((height, width) + part.shape[2:], part.dtype)
    out[y:y + h, x:x + w] = part
    return out


def encode_png(image: np.ndarray) -> bytes:
    """PNG bytes of an (H, W, 4) uint8 RGBA image or an (H, W) bool mask (1-bit PNG).

    zlib level 1 with the single "sub" row filter: about as small as PIL's default for
    sprites (+3 %) and 1.5-2x faster to write, which is most of a data set build's time.
    """
    if image.dtype == bool:
        params = [cv2.IMWRITE_PNG_BILEVEL, 1, cv2.IMWRITE_PNG_COMPRESSION, 1]
        data = np.where(image, 255, 0).astype(np.uint8)
    else:
        params = [cv2.IMWRITE_PNG_COMPRESSION, 1, cv2.IMWRITE_PNG_FILTER, cv2.IMWRITE_PNG_FILTER_SUB]
        data = cv2.cvtColor(np.ascontiguousarray(image), cv2.COLOR_RGBA2BGRA)
    ok, buf = cv2.imencode(".png", data, params)
    if not ok:
        raise ValueError(f"PNG encoding failed for an array of shape {image.shape}")
    return buf.tobytes()


def encode_mesh(mesh: dict) -> bytes:
    """``.npz`` bytes of a mesh dict (vertices, triangles, hull, edges)."""
    buf = io.BytesIO()
    np.savez(buf, **mesh)
    return buf.getvalue()


#: The arrays of a sample's mesh: name -> (kind of number, columns; None for a list).
MESH_ARRAYS = {"vertices": ("f", 2), "triangles": ("i", 3), "hull": ("i", None), "edges": ("i", 2)}


def checked_mesh(data: bytes) -> dict:
    """The mesh of a data set's ``.npz`` member (:func:`encode_mesh`), checked as an index row is
    (:func:`checked_row`): its arrays of :data:`MESH_ARRAYS`' kinds and shapes, together at most
    :data:`MAX_MEMBER_BYTES` unpacked (read from the archive's directory before any is), the
    vertices finite, every index one of them.

    Raises
    ------
    ValueError
        Saying what is of another form (the caller names the file and the sample).
    """
    import zipfile

    def unreadable(e: Exception) -> ValueError:  # not an .npz (numpy: "pickled data"), cut short
        return ValueError(f"not a numpy .npz archive ({type(e).__name__}: {str(e)[:80]})")

    try:
        z = np.load(io.BytesIO(data), allow_pickle=False)
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as e:
        raise unreadable(e) from None
    if not isinstance(z, np.lib.npyio.NpzFile):
        raise ValueError("one array, not a numpy .npz archive")
    with z:
        unpacked = sum(info.file_size for info in z.zip.infolist())
        if unpacked > MAX_MEMBER_BYTES:
            raise ValueError(f"{unpacked:,} bytes unpacked, more than {MAX_MEMBER_BYTES:,}")
        missing = set(MESH_ARRAYS) - set(z.files)
        if missing:
            raise ValueError(f"no {', '.join(sorted(missing))} array")
        try:
            mesh = {k: z[k] for k in MESH_ARRAYS}
        except (ValueError, OSError, EOFError, zipfile.BadZipFile) as e:
            raise unreadable(e) from None
    for name, (kind, columns) in MESH_ARRAYS.items():
        a = mesh[name]
        if a.dtype.kind not in (kind, "u" if kind == "i" else kind) or \
                a.ndim != (1 if columns is None else 2) or (columns is not None and a.shape[1] != columns):
            raise ValueError(f"{name} is an array of {a.dtype} {a.shape}, not "
                             f"{'numbers' if kind == 'f' else 'indices'} in {columns or 1} column(s)")
    n = len(mesh["vertices"])
    if not np.isfinite(mesh["vertices"]).all():
        raise ValueError("a vertex is not a finite number")
    for name in ("triangles", "hull", "edges"):
        a = mesh[name]
        if a.size and (a.min() < 0 or a.max() >= n):
            raise ValueError(f"{name} index {int(a.max() if a.max() >= n else a.min())} is not one of its {n} vertices")
    return mesh


def read_jsonl(path: Path) -> Iterator[dict]:
    """Rows of a JSONL file, streamed; a torn last line (killed writer) is skipped."""
    if not path.is_file():
        return
    with open(path, "rb") as f:
        for number, line in enumerate(f, 1):
            if not line.endswith(b"\n"):
                break
            try:
                yield json.loads(line)
            except ValueError as e:  # a line broken in the middle of the file: not a torn tail
                raise SpineMeshError(f"unreadable row ({e})", path, line=number) from None


def repair_tail(path: Path) -> None:
    """Cut a torn last line off a JSONL file so that appends start on a fresh line."""
    if not path.is_file():
        return
    with open(path, "rb+") as f:
        size = f.seek(0, os.SEEK_END)
        if size == 0:
            return
        f.seek(size - 1)
        if f.read(1) == b"\n":
            return
        # Walk back to the last newline; JSONL rows are short, so this reads little.
        pos = size
        while pos > 0:
            step = min(65536, pos)
            f.seek(pos - step)
            chunk = f.read(step)
            nl = chunk.rfind(b"\n")
            if nl >= 0:
                f.truncate(pos - step + nl + 1)
                return
            pos -= step
        f.truncate(0)


def append_jsonl(path: Path, rows: list[dict]) -> None:
    """Append rows with one write and an fsync (see the module notes on crash safety)."""
    if not rows:
        return
    data = "".join(json.dumps(r, ensure_ascii=False, separators=(",", ":")) + "\n" for r in rows)
    with open(path, "ab") as f:
        # a path in a problem line may hold a file name's bytes that are not UTF-8: U+FFFD each
        f.write(name_as_text(data).encode("utf-8"))
        f.flush()
        os.fsync(f.fileno())


def write_shard(path: Path, members: list[tuple[str, bytes]]) -> dict[str, tuple[int, int]]:
    """Write a tar shard atomically and return ``{member name: (data offset, size)}``.

    The offsets are those of the data as written (each member's data follows its header and
    is padded to whole 512-byte blocks), which is where a reader finds it.
    """
    offsets = {}

    def write(f) -> None:
        with tarfile.open(fileobj=f, mode="w", format=tarfile.USTAR_FORMAT) as tar:
            for name, data in members:
                info = tarfile.TarInfo(name)
                info.size = len(data)
                info.mode = 0o644
                tar.addfile(info, io.BytesIO(data))
                # the data ends the member, padded to whole blocks: where it starts, as a reader finds it
                padded = -(-len(data) // tarfile.BLOCKSIZE) * tarfile.BLOCKSIZE
                offsets[name] = (tar.offset - padded, len(data))

    # a uniquely named temporary file, flushed to disk, renamed; removed whatever stops the write
    atomic_write_stream(path, write)
    return offsets


class Dataset:
    """A data set folder written by :func:`spinemesh.dataset.build_dataset`.

    Opening reads only ``meta.json``; :meth:`rows` streams the index, and the ``load_*``
    methods read one member straight from its shard (a few open files are cached, so the
    object can be used from one process or thread at a time; open one per worker).
    """

    def __init__(self, root: str | Path, max_open: int = 16):
        self.root = Path(root)
        meta_path = self.root / META
        if not meta_path.is_file():
            raise SpineMeshError("not a spinemesh data set (no meta.json)", self.root)
        try:
            self.meta = json.loads(meta_path.read_text("utf-8"))
        except (OSError, ValueError) as e:
            raise SpineMeshError(f"unreadable meta.json: {e}", meta_path) from None
        if self.meta.get("format") != FORMAT or self.meta.get("version") != FORMAT_VERSION:
            raise SpineMeshError(f"unsupported data set format {self.meta.get('format')!r} "
                                 f"version {self.meta.get('version')!r}", meta_path)
        self._files: OrderedDict[str, int] = OrderedDict()
        self._max_open = max_open
        self._shards: dict[str, Path] = {}  # shard paths as rows write them -> real paths inside root

    def rows(self, split: str | None = None) -> Iterator[dict]:
        """Index rows in write order; ``split`` None (all), ``"train"`` or ``"val"``."""
        if split not in (None, "train", "val"):
            raise ValueError(f"split must be None, 'train' or 'val', not {split!r}")
        index = self.root / INDEX
        for line, row in enumerate(read_jsonl(index), 1):  # one row a line; a torn last one is not read
            row = checked_row(row, self.root, index, line, self._shards)
            if split is None or row["split"] == split:
                yield row

    def projects(self) -> Iterator[dict]:
        """One row per processed project: name, game, counts, errors."""
        return read_jsonl(self.root / PROJECTS)

    def _read(self, row: dict, member: str) -> bytes:
        shard = row["shard"]
        fd = self._files.get(shard)
        if fd is None:
            # inside the data set, as its row was checked (a row given by a caller is checked here)
            path = self._shards.get(shard) or _shard_path(self.root, shard, self.root / INDEX)
            try:
                fd = os.open(path, os.O_RDONLY)
            except FileNotFoundError:
                raise SpineMeshError(f"shard not found (sample {row['id']})", self.root / shard) from None
            self._files[shard] = fd
            while len(self._files) > self._max_open:
                os.close(self._files.popitem(last=False)[1])
        else:
            self._files.move_to_end(shard)
        offset, size = row[member]
        data = os.pread(fd, size, offset)
        if len(data) != size:
            raise SpineMeshError(f"shard is shorter than the index says (sample {row['id']})",
                                 self.root / shard, offset=offset)
        return data

    def load_image(self, row: dict) -> np.ndarray:
        """The sample's RGBA image, (H, W, 4) uint8, straight alpha."""
        part = self._decoded(row, "image")
        return uncrop(self._boxed(part, row), row["box"], row["width"], row["height"])

    def load_mask(self, row: dict) -> np.ndarray:
        """The sample's mask (alpha > 128), (H, W) bool."""
        part = self._decoded(row, "mask")[..., 0] > 127  # a 1-bit PNG: its set bits read 255
        return uncrop(self._boxed(part, row), row["box"], row["width"], row["height"])

    def _decoded(self, row: dict, member: str) -> np.ndarray:
        """A member's image, (h, w, 4) uint8, decoded as every image is (its size checked before
        its pixels, :func:`spinemesh.images.decode.decode_rgba`), refused in one line naming the shard and
        the sample: junk bytes were a Pillow traceback, a mask of 100000x100000 pixels no error."""
        shard = self.root / row["shard"]
        try:
            return decode_rgba(self._read(row, member), shard)
        except (ImageError, LimitError) as e:
            raise type(e)(f"sample {row['id']}: its {member}: {e.message}", shard) from None

    def _boxed(self, part: np.ndarray, row: dict) -> np.ndarray:
        """``part``, refused in one line unless it is the size of the row's box (a broadcast error)."""
        w, h = row["box"][2:]
        if part.shape[:2] != (h, w):
            raise SpineMeshError(f"sample {row['id']}: its member is {part.shape[1]}x{part.shape[0]}, its box "
                                 f"{w}x{h}", self.root / row["shard"])
        return part

    def load_mesh(self, row: dict) -> dict | None:
        """The artist mesh in pixels (see the module notes), or None for region samples."""
        if not row.get("mesh"):
            return None
        try:
            return checked_mesh(self._read(row, "mesh"))
        except ValueError as e:
            raise SpineMeshError(f"sample {row['id']}: its mesh is of another form: {e}",
                                 self.root / row["shard"]) from None

    def close(self) -> None:
        for fd in self._files.values():
            os.close(fd)
        self._files.clear()

    def __enter__(self) -> "Dataset":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self) -> None:
        if not hasattr(self, "_files"):  # __init__ refused the folder before opening anything
            return
        try:
            self.close()
        except OSError:  # a descriptor already gone at interpreter exit
            pass


def open_dataset(path: str | Path) -> Dataset:
    """Open a data set folder; cheap (reads ``meta.json`` only). See :class:`Dataset`.

    Parameters
    ----------
    path : path
        A folder written by :func:`spinemesh.dataset.build_dataset` (``spinemesh dataset``).

    Returns
    -------
    Dataset
        Its rows streamed from the index, each member read from its shard when asked for.

    Raises
    ------
    SpineMeshError
        For a folder without ``meta.json``, or of another format or version.
    """
    return Dataset(path)
