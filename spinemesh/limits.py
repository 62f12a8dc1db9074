"""Resource limits on input, so that a small hostile file cannot exhaust memory or time.

Each limit is set by what the value makes the program do (memory, time, the size of what it
implies), lies far above what real Spine projects use and is checked where the value is read,
raising :class:`~spinemesh.errors.LimitError` that names the file. ``scripts/measure_limits.py``
prints the largest values of the official examples and the game corpus beside the limits
(largest found: 606 regions in one atlas, 1,042 attachments in one skeleton, page scale 0.2,
numbers of 10,420 in attachments and 5,448 in bones).
"""

from __future__ import annotations

from .errors import LimitError

#: Largest image, page or original region size, in pixels (Pillow's own bomb threshold,
#: about 9459 x 9459; the Spine editor packs pages of at most 8192 x 8192 = 67 Mpx).
MAX_IMAGE_PIXELS = 89_478_485

#: Largest width or height of one image, page or original region, in pixels.
MAX_IMAGE_SIDE = 16_384

#: Most frames in one sequence attachment (real projects use tens).
MAX_SEQUENCE_FRAMES = 10_000

#: Most zero-padding digits of a sequence frame number.
MAX_SEQUENCE_DIGITS = 9

#: Deepest nesting of arrays and objects in a skeleton JSON (real ones reach about 8).
MAX_JSON_DEPTH = 100


#: Smallest atlas page ``scale:``. A page exported at scale ``s`` stands for original images
#: ``1 / s`` times its size: the editor images written back (``upgrade --images``) and the
#: sizes the mesher works in grow with ``1 / s`` (a 76 x 72 region at ``scale: 0.002`` would
#: ask for a 38000 x 36000 image). The editor's export dialog offers scales down to 0.01.
MIN_ATLAS_SCALE = 0.001

#: Largest atlas page ``scale:`` (pages are exported at most a few times up, for high-DPI art).
MAX_ATLAS_SCALE = 1000.0

#: Most regions in one atlas. Each region costs about a kilobyte once parsed: the limit bounds
#: an atlas's memory to about 100 MB, whatever its file size.
MAX_ATLAS_REGIONS = 100_000

#: Most attachments in one skeleton. Each is planned, possibly meshed and written: memory and
#: time grow with the count (about 2 KB and 50 microseconds of writing each).
MAX_ATTACHMENTS = 200_000

#: Largest magnitude of a number the program computes with (coordinates, sizes, scales,
#: rotations, mixes, mesh vertices). Products of up to four such values (a vertex: position +
#: size x scale x cosine, then a bone's transform) stay far inside the float32 range of the
#: binary format (3.4e38), so no value can overflow to infinity; an integer of hundreds of
#: digits or ``1e300`` is refused where it is read.
MAX_SKELETON_NUMBER = 1e9


def check_image_size(width: int, height: int, what: str, source=None, line: int | None = None) -> None:
    """Refuse an image, page or region whose size exceeds the limits above.

    Raises
    ------
    LimitError
        Naming ``what`` (e.g. ``"region 'head' original size"``) and the file.
    """
    if width > MAX_IMAGE_SIDE or height > MAX_IMAGE_SIDE or width * height > MAX_IMAGE_PIXELS:
        raise LimitError(f"{what} {width}x{height} exceeds the limit of {MAX_IMAGE_SIDE} pixels a side "
                         f"and {MAX_IMAGE_PIXELS:,} pixels", source, line=line)


#: Most items one binary skeleton may list, all its lengths summed (bones, slots, skins, their
#: attachments, vertices, animations, timelines, keys): each costs tens to hundreds of bytes of
#: memory once read (a key of 5 bytes in the file is a dict of about 250), so a 5 MB ``.skel`` of
#: attachment keys took 250 MB. The largest real skeleton lists 70,560; a million costs at most
#: a few hundred MB and tens of seconds.
MAX_SKELETON_ITEMS = 1_000_000


#: Largest skeleton or atlas file read whole into memory (real ones stay under 50 MB).
MAX_DOCUMENT_BYTES = 256 * 1024 * 1024


def check_file_size(path, what: str) -> None:
    """Refuse a ``what`` file (skeleton, atlas) that is not a regular file or is larger than
    :data:`MAX_DOCUMENT_BYTES` (a FIFO would block for ever when read)."""
    import os

    from .files.inputs import regular_file

    regular_file(path, what)
    size = os.stat(path).st_size
    if size > MAX_DOCUMENT_BYTES:
        raise LimitError(f"{what} of {size:,} bytes exceeds the limit of {MAX_DOCUMENT_BYTES:,} bytes", path)


#: Decoded atlas pages a project keeps in memory at once (bytes of texels): each page is then
#: decoded once however many skeletons share it, up to 64 pages of 2048x2048.
MAX_PAGE_STORE_BYTES = 1 << 30

#: Most game-loop steps (time times steps per second) ``spinemesh pose`` takes to reach one
#: time: a pose with physics replays every step from 0, a few milliseconds each.
MAX_POSE_STEPS = 100_000

#: Most steps a second a physics constraint (4.2, 4.3) is stepped at (its ``fps``; 60 by default, 24 to
#: 60 in real projects): each 1/60 s frame costs ``fps / 60`` steps, so an ``fps`` of 1e9 would
#: make one frame millions of steps. Finer constraints are not stepped; their bones are flagged.
MAX_PHYSICS_FPS = 1000

#: Largest JSON ``spinemesh pose`` writes in one call, estimated before sampling as the setup
#: pose's size times the poses asked for. Poses are written as a stream (one held at a time), so
#: this bounds the time and disk of a call, not its memory: 10,000 times (the most) of the largest
#: real skeleton, 0.49 MB a pose, write 4.9 GB; a pose of over 1.7 MB is needed to reach it. To a
#: file, the estimate must also fit in the space free where it is written.
MAX_POSE_OUTPUT_BYTES = 16 * 1024**3

#: Most worker processes a command starts (``--jobs``): a process per task for a mistyped
#: 100000 would start thousands; machines with more cores than this use ``--dask``.
MAX_JOBS = 256
