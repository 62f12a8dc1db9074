"""The preview's animation player: original and upgraded skeletons side by side, one time line.

Python samples the poses with :mod:`spinemesh.anim` (:mod:`.frames`: every drawn
attachment's world vertices, frame by frame, quantised) and writes them as small scripts beside the pages (:mod:`.page`,
:mod:`.files`); the page's player (:file:`player.js`) draws textured triangles from the page's
images on a 2D canvas. Chosen over pre-rendered frames (pictures weigh far more than
vertices, and wireframes and bone colours would double them) and over WebGL (absent in
headless browsers without a GPU); it works from a ``file://`` URL with no network.
"""

from .files import PreviewFolder
from .frames import Animation, Drawn, animations
from .page import PLAYER_CSS, write_player

__all__ = ["PLAYER_CSS", "Animation", "Drawn", "PreviewFolder", "animations", "write_player"]
