"""A name found in a skeleton's list as the runtimes find it: one lookup the JSON side
(:mod:`spinemesh.skeleton`, the pose sampler) and the binary side
(:mod:`spinemesh.skeleton_binary`) share.
"""

from __future__ import annotations


def first_of_each_name(names) -> dict:
    """Name -> place of the first item of that name, as the runtimes find a slot (``findSlot``:
    the first whose name matches). No editor names two slots alike (two bones alike are refused,
    :func:`spinemesh.skeleton_check.bone_tree_problem`); a file that does is posed as a game
    poses it, the later slot never found by its name (a timeline or a skin naming it gets the
    first).

    Examples
    --------
    >>> first_of_each_name(["a", "b", "a"])
    {'a': 0, 'b': 1}
    """
    out: dict = {}
    for i, name in enumerate(names):
        out.setdefault(name, i)
    return out
