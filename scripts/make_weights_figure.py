"""The README's weights picture, drawn by our own code from our own worm project.

    .venv/bin/python scripts/make_weights_figure.py            # writes docs/weights-preview.png

Builds the worm project of ``tests/rig_project.py`` (one striped sprite, three bones in a
chain), upgrades it with ``--weights auto`` and draws the weights preview of its mesh
(``spinemesh weights --preview``): vertices coloured by bone, and the mesh in a bent pose.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))

from rig_project import make_worm_project  # noqa: E402

from spinemesh.rig.document import WeightOptions  # noqa: E402
from spinemesh.rig.run import weight_project  # noqa: E402
from spinemesh.upgrade import Options, upgrade_project  # noqa: E402


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        skeleton = make_worm_project(tmp / "worm")
        upgrade_project(skeleton.parent, tmp / "upgraded", Options(weights="auto"))
        # --replace --bones keep: the same bones and weights again, only to draw the preview
        weight_project(tmp / "upgraded", tmp / "again", WeightOptions(bones="keep", replace=True),
                       preview=tmp / "preview")
        image = np.asarray(Image.open(next((tmp / "preview").glob("*.png"))))
        rows = np.flatnonzero((image != image[0, 0]).any(axis=(1, 2)))
        image = image[max(rows[0] - 8, 0): rows[-1] + 8]  # crop the empty band above and below
        out = REPO / "docs" / "images" / "weights-preview.png"
        out.parent.mkdir(exist_ok=True)
        Image.fromarray(image).save(out, optimize=True)
        print(out, image.shape)


if __name__ == "__main__":
    main()
