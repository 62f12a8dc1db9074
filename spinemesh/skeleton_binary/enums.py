"""Names that the binary format stores as small integers, shared by every version.

A table lists the names in the order of their integer codes. Versions that add names extend
a table (see ``SPACING_MODE`` in :mod:`.v4`); those that keep it import it from here.
"""

#: Key of the binary-only information in a document (whether the file has nonessential
#: data, the string table); see the module docstrings of :mod:`.v3` and :mod:`.v4`.
EXTRA = "_skel"


def extra_to_write(writer, doc: dict) -> dict:
    """What a document to be written keeps under :data:`EXTRA` (empty when it is not an
    object); ``writer.fail`` when the document itself is not one."""
    if not isinstance(doc, dict):
        raise writer.fail(f"a skeleton document (a JSON object), got {type(doc).__name__}")
    extra = doc.get(EXTRA, {})
    return extra if isinstance(extra, dict) else {}

ATTACHMENT_TYPES = ("region", "boundingbox", "mesh", "linkedmesh", "path", "point", "clipping")
#: A bone's transform mode (3.x) or inherit mode (4.x): the same five names in both.
INHERIT = ("normal", "onlyTranslation", "noRotationOrReflection", "noScale", "noScaleOrReflection")
BLEND = ("normal", "additive", "multiply", "screen")
POSITION_MODE = ("fixed", "percent")
ROTATE_MODE = ("tangent", "chain", "chainScale")

#: How a timeline frame curves to the next: the codes both versions store.
CURVE_LINEAR, CURVE_STEPPED, CURVE_BEZIER = 0, 1, 2
