"""``spinemesh pack``: atlas pages packed anew by the outlines of the meshes that draw each region.

:mod:`.uses` finds how every skeleton draws each region; :mod:`.outlines` turns that into the
texels each region must keep (its footprint); :mod:`.place` places footprints on pages;
:mod:`.atlas_pack` packs one atlas and rewrites its regions; :mod:`.run` packs whole projects
and libraries into an output folder, with a report (:mod:`.report`). Each page written is
encoded losslessly and decoded back (:mod:`.page_files`), carrying what its original pages say
of their colours (:mod:`.page_colours`); :mod:`.checks` holds every rule that keeps an atlas as
it was.
"""
