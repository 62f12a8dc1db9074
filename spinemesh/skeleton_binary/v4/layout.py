"""What each 4.x minor version stores, and what the declarations carry between structures."""

from __future__ import annotations


SPACING_MODE = ("length", "fixed", "percent", "proportional")
SEQUENCE_MODE = ("hold", "once", "loop", "pingpong", "onceReverse", "loopReverse", "pingpongReverse")
class Layout:
    """What one 4.x minor version stores, as flags read by the declarations.

    Parameters
    ----------
    version : str
        The editor version from the header, e.g. ``"4.2.22"``.
    """

    def __init__(self, version: str):
        self.version = version
        self.minor = int(version.split(".")[1])
        self.flags = self.minor >= 2                 # optional fields behind flag bytes
        self.physics = self.minor >= 2
        self.reference_scale = self.minor >= 2
        self.inherit_key = "inherit" if self.minor >= 2 else "transform"
        self.names_are_refs = self.minor < 2         # skin and event names as string refs
        self.sequences = self.minor >= 1
        self.attachment_timelines = self.minor >= 1  # "attachments": deform + sequence
        self.linked_key = "timelines" if self.minor >= 1 else "deform"
        self.short_arrays = self.minor < 2           # triangles, edges as int16


def _layout(s, version: str) -> Layout:
    parts = version.split(".")
    if len(parts) < 2 or not parts[1].isdigit() or parts[0] != "4" or int(parts[1]) > 2:
        raise s.fail(f"Spine 4.0, 4.1 or 4.2, found version {version!r}", 8)
    return Layout(version)


class Context:
    """What the declarations need beyond their own node: the layout and name tables."""

    def __init__(self, layout: Layout, nonessential: bool):
        self.L = layout
        self.nonessential = nonessential
        self.bones = self.slots = self.ik = self.transform = self.path = self.physics = ([], {})
        self.skins = ([], {})
        self.events: list[dict] = []
        self.event_names = ([], {})
        #: 4.2 linked meshes read before their skin's name is known: (node, offset).
        self.linked: list = []
