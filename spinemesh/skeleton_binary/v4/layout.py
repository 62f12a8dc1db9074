"""What each 4.x minor version stores, and what the declarations carry between structures."""

from __future__ import annotations

from ...skeleton_version import major_minor

SPACING_MODE = ("length", "fixed", "percent", "proportional")
SEQUENCE_MODE = ("hold", "once", "loop", "pingpong", "onceReverse", "loopReverse", "pingpongReverse")
#: 4.3: what a transform constraint or slider reads from a bone, and what it writes to.
PROPERTIES = ("rotate", "x", "y", "scaleX", "scaleY", "shearY")
#: 4.3: how IK and physics constraints change scaleY.
SCALE_Y_MODE = ("none", "uniform", "volume")


class Layout:
    """What one 4.x minor version stores, as flags read by the declarations.

    Parameters
    ----------
    version : str
        The editor version from the header, e.g. ``"4.2.22"``.
    """

    def __init__(self, version: str):
        self.version = version
        self.minor = major_minor(version)[1]
        self.flags = self.minor >= 2                 # optional fields behind flag bytes
        self.physics = self.minor >= 2
        self.reference_scale = self.minor >= 2
        self.inherit_key = "inherit" if self.minor >= 2 else "transform"
        self.names_are_refs = self.minor < 2         # skin and event names as string refs
        self.sequences = self.minor >= 1
        self.attachment_timelines = self.minor >= 1  # "attachments": deform + sequence
        self.linked_key = "timelines" if self.minor >= 1 else "deform"
        self.short_arrays = self.minor < 2           # triangles, edges as int16
        # an attachment key with no attachment: the 4.0 editor exports "name": null, 4.1 on leave
        # the field out (the binary stores a null string either way)
        self.null_attachment_names = self.minor < 1
        # 4.3 keeps every constraint in one list ("constraints", each with its "type", sliders
        # new), which skins and timelines index; bones store their length after the
        # inherit mode and an icon size and rotation; weighted vertices are preceded by the
        # length of their bone list; meshes list the slots of linked meshes that share their
        # timelines, linked meshes name their source's slot; clipping can be convex or
        # inverse; animations gain draw order folders and a colour.
        self.constraint_list = self.minor >= 3


def _layout(s, version: str) -> Layout:
    known = major_minor(version)  # "4.1-from-4.2.33": a 4.1 file that editor 4.2 exported
    if not (known and known[0] == 4 and known[1] <= 3):
        raise s.fail(f"Spine 4.0 to 4.3, found version {version!r}", 8)
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
        #: 4.3: the one constraint list, as (types, names, {(type, name): index}).
        self.constraints: tuple = ([], [], {})
        self.sliders = ([], {})
        #: 4.3: the skin and slot whose attachments are being read or written.
        self.skin_name = "default"
        self.slot_name = None
        #: 4.3: mesh timeline slots as read, by (skin, slot, attachment); as written.
        self.timeline_slots: dict = {}
