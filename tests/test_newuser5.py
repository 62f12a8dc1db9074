"""A new user walks the guides a fifth time, on real projects of every Spine version (3.5 to 4.3):
what they met that the program said badly, each test failing on the code before its fix.

Everything runs on the demo project drawn by our own code (no outside data needed).
"""

from __future__ import annotations

from types import SimpleNamespace


def _pack_table(rows: list, columns: int) -> str:
    from spinemesh.cli import pack as pack_cli

    console = pack_cli.console
    width = console.width
    try:
        console.width = columns
        with console.capture() as got:
            pack_cli.print_pack_table(rows)
        return got.get()
    finally:
        console.width = width


def _atlas_row(name: str, texels: tuple[int, int], size: tuple[int, int]) -> SimpleNamespace:
    return SimpleNamespace(atlas=name, pages_before=1, pages_after=1, texels_before=texels[0], texels_after=texels[1],
                           bytes_before=size[0], bytes_after=size[1], by_outline=25, by_rectangle=5, reason="")


def test_the_pack_table_names_each_atlas_at_80_columns():
    """At 80 columns (a CI log, a pipe) the table cut every atlas's name to a few letters
    (``HalloweenC…``, ``Waiter_417Down.at…``: the corpus's halloween-creature and cafe-waiter),
    so the log did not say which atlas was packed; the figures wrap instead, none cut."""
    for row in (_atlas_row("HalloweenCreature.atlas", (192_604, 162_782), (95_490, 81_902)),
                _atlas_row("Waiter_417Down.atlas", (6_714_663, 5_138_813), (4_296_671, 2_725_174))):
        text = _pack_table([row], 80)
        assert f"│ {row.atlas} " in text, text
        for figure in (row.texels_before, row.texels_after, row.bytes_before, row.bytes_after):
            assert f"{figure:,}" in text, text
        assert "1 -> 1" in text, text  # a short cell is not wrapped to make room
        assert all(len(line) <= 80 for line in text.splitlines()), text
    # a name longer than the room left keeps its end (which file) and stays told apart
    long = [_atlas_row(f"studio-export-december/characters/{n}/people_Max_pal.atlas.txt", (4096, 2048), (900, 800))
            for n in ("max", "mia")]
    text = _pack_table(long, 80)
    names = [line.split("│")[1].strip() for line in text.splitlines() if line.startswith("│")
             and line.split("│")[1].strip() not in ("", "total")]
    assert len(names) == 2 and len(set(names)) == 2 and all(n.endswith(".atlas.txt") for n in names), text
    assert all(len(line) <= 80 for line in text.splitlines()), text
