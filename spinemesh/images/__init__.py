"""Original-size images of attachments, from atlas pages or from a plain images folder.

An atlas stores each image trimmed of transparent borders, possibly rotated, possibly
premultiplied and possibly scaled. :class:`~.sources.AtlasImages` undoes all of that except
the scale: it returns the image at its original size *in atlas pixels* and reports the page
scale, so that ``skeleton units = atlas pixels / scale``.

:class:`~.sources.FolderImages` reads the unpacked images the Spine editor works from
(``images/<path>.png``), so a skeleton can be processed without any atlas.

One module per idea, each importing only those above it in this list:

- :mod:`.png_rows`: a PNG's rows inflated by libdeflate ahead of libpng (the fast path);
- :mod:`.decode`: image files to RGBA texels, the one place the package decodes them;
- :mod:`.texels`: arithmetic on texels (premultiplied or straight, faint, shrunk);
- :mod:`.regions`: a region cut out of its page, upright at its original size;
- :mod:`.content_ids`: the one image hash of the package;
- :mod:`.pages`: decoded pages kept once per project, and decoded ahead on workers;
- :mod:`.sources`: :class:`~.sources.RegionImage` and the two image sources.

Each caller imports from the module that holds the name (this package re-exports nothing), so a
test that patches a function patches it where its callers look it up.
"""
