"""Training data from Spine projects: attachment images, masks and artist meshes.

The paper (sec. 4, "Dataset") trained its segmentation network on 100,363 attachment
images of 172 games, cut out of their atlases with the skeletons' own parsers. This
package builds such a set from any folders of Spine projects:

- :func:`build_dataset` (``spinemesh dataset``): every unique image (by content hash,
  within and across projects) of every region, mesh and linked-mesh attachment, sequence
  frames included, with its mask and, for meshes, the artist's vertices in pixels;
- :func:`open_dataset`: the streaming, random-access reader a training loop uses;
- :func:`dataset_stats` / :func:`plot_stats` (``spinemesh dataset-stats``).

The on-disk format is described in :mod:`spinemesh.dataset.format`; which folders are
projects and games, and how the 90/10 split is drawn, in :mod:`spinemesh.dataset.extract`.
"""

from .build import Summary, build_dataset  # noqa: F401
from .extract import content_id, extract_project, find_projects, game_of, mesh_pixels, split_of  # noqa: F401
from .format import Dataset, mask_of, open_dataset  # noqa: F401
from .stats import dataset_stats, plot_stats  # noqa: F401
