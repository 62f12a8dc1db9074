"""Mesher parameters and the named presets.

Every field of :class:`MesherParams` can be overridden per call:
``mesh_image(img, preset="default", density=2.0, max_vertices=60)``.

Two presets:

``paper``
    Exactly the parameters of section 3 of the *SpriteToMesh* paper: alpha
    threshold 128, DP with 0.003 P and 50 target exterior vertices, bilateral + multi-channel
    Canny interior vertices, plain Delaunay with the centroid-in-mask filter. Use it to
    reproduce and compare the paper's numbers; it may clip art and may leave several loops.
``default``
    Built for animation: a hull that never clips art (every pixel with alpha >= 8 lies inside),
    artist-like sparseness, the interior colour boundaries kept as constrained triangle edges,
    holes kept open, islands joined into one hull loop, good triangle angles.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace


@dataclass(frozen=True)
class MesherParams:
    """All knobs of the pipeline. Lengths are in pixels of the original image.

    Attributes
    ----------
    style : {"paper", "default"}
        Which exterior/triangulation algorithm runs (see module docstring).
    alpha_threshold : int
        A pixel is foreground when ``alpha >= alpha_threshold`` (0..255). Paper (sec. 3.1):
        ``alpha > 128``, i.e. 129 here. Default 8: faint glow and anti-aliasing are art too.
    mask_source : {"alpha", "model", "auto"}
        Where the mask comes from (sec. 3.1); see :func:`spinemesh.mesher.mask.compute_mask`.
    mask_blur_sigma : float
        Gaussian sigma (px) applied to the mask before the paper's contour extraction (sec. 3.2).
    min_component_area : float
        Paper (sec. 3.2): components smaller than this (px^2) are ignored. The default preset
        never ignores any pixel, so it uses 0.
    dp_epsilon_ratio : float
        Paper (sec. 3.2): Douglas-Peucker tolerance as a share of the contour perimeter (0.003).
    n_target : int
        Paper (sec. 3.2): target count of exterior vertices for arc subdivision (50).
    hull_tolerance : float
        Default preset: how far (px, before ``density`` scaling) the simplified hull may stray
        outside the art, as a share of sqrt(mask area); the hull is always pushed out so that it
        contains the art, this only trades waste for vertices.
    bilateral_d, bilateral_sigma_color, bilateral_sigma_space : int, float, float
        Paper (sec. 3.3 step 1): 9, 75, 75.
    canny_low, canny_high : int
        Paper (sec. 3.3 step 2): 40, 120 on gray, R, G and B, OR-ed.
    erode_kernel, erode_iterations : int
        Paper (sec. 3.3 step 3): the edge map is masked by the mask eroded 11x11, twice.
    close_kernel : int
        Paper (sec. 3.3 step 3): morphological closing 3x3.
    min_contour_length : float
        Paper (sec. 3.3 step 4): interior contours shorter than this (px) are dropped (150).
    interior_dp_ratio : float
        Paper (sec. 3.3 step 4): DP tolerance as a share of the contour arc length (0.012).
    max_segment : float
        Paper (sec. 3.3 step 4): interior segments longer than this (px) are split (40).
    border_distance : float
        Paper (sec. 3.3 step 4): interior vertices keep at least this distance (px) from the mask
        border (6).
    dedup_radius : float
        Paper (sec. 3.3 step 5): interior vertices closer than this (px) are merged (18).
    triangulation_dedup : float
        Paper (sec. 3.4): vertices within this distance (px) are merged before Delaunay (2).
    density : float
        Default preset: multiplies vertex density. 1 is artist-like; about 4 approaches the
        paper's density. Interior spacing and hull tolerance divide by it; the refinement
        budget multiplies by it.
    max_vertices : int or None
        Hard budget on the vertex count (None: no limit). Interior vertices go first, then the
        hull is simplified further. Never below what the hull needs to cover the art (>= 3).
    min_vertex_distance : float
        Default preset: no two vertices closer than this (px).
    fill_ratio : float
        Default preset: the constrained Delaunay refinement (Ruppert-style Steiner points, which
        lift small angles) may add this share of the placed vertices; 0 disables.
    min_angle : float
        Default preset: refinement goal for the smallest triangle angle (degrees).
    max_fill_vertices : int
        Default preset: at most this many refinement vertices (times ``density``).
    min_hole_area : float
        Default preset: transparent holes smaller than this (px^2) are meshed over.
    analysis_max_side : int
        Default preset: images larger than this are analysed on an integer-downscaled copy
        (the coverage mask is max-pooled, so the hull still covers every full-size pixel).
    interior_max_side : int
        Default preset: interior edges are detected on a copy at most this large (0: full
        size). The paper preset always works at full size.
    max_hull_tolerance : float
        Default preset: upper bound (px) on the hull tolerance, whatever the art's size (0:
        none). The tolerance grows with sqrt(mask area), so on large art a hull may stray tens
        of pixels outside it to save a few vertices.
    hull_inset : float
        Default preset: how far (px) the hull may lie inside the squares of the mask's
        pixels, off the image border (0). ``upgrade`` grows the art by one texel for bilinear
        sampling, which reaches only half a texel beyond a texel's square, and sets 0.5.
    min_saving : float or None
        Default preset: None meshes whatever the cost. A share (0..1) turns on the rules of
        :mod:`spinemesh.mesher.worth`: :class:`~spinemesh.mesher.worth.NotWorthMeshing` is
        raised, early, when the mesh would draw less than this share fewer pixels than the
        image's quad, or would need too many vertices (``upgrade --min-saving``).
    """

    style: str = "default"
    alpha_threshold: int = 8
    mask_source: str = "alpha"
    mask_blur_sigma: float = 1.0
    min_component_area: float = 0.0
    dp_epsilon_ratio: float = 0.003
    n_target: int = 50
    hull_tolerance: float = 0.04
    bilateral_d: int = 9
    bilateral_sigma_color: float = 75.0
    bilateral_sigma_space: float = 75.0
    canny_low: int = 40
    canny_high: int = 120
    erode_kernel: int = 11
    erode_iterations: int = 2
    close_kernel: int = 3
    min_contour_length: float = 150.0
    interior_dp_ratio: float = 0.012
    max_segment: float = 40.0
    border_distance: float = 6.0
    dedup_radius: float = 18.0
    triangulation_dedup: float = 2.0
    density: float = 1.0
    max_vertices: int | None = None
    min_vertex_distance: float = 2.0
    fill_ratio: float = 0.0
    min_angle: float = 0.0
    max_fill_vertices: int = 40
    min_hole_area: float = 400.0
    analysis_max_side: int = 1024
    interior_max_side: int = 512
    max_hull_tolerance: float = 0.0
    hull_inset: float = 0.0
    min_saving: float | None = None

    def with_overrides(self, **overrides) -> "MesherParams":
        """A copy with some fields replaced; unknown names raise ``TypeError``."""
        known = {f.name for f in fields(self)}
        unknown = sorted(set(overrides) - known)
        if unknown:
            raise TypeError(f"unknown mesher parameter(s): {', '.join(unknown)}; "
                            f"known: {', '.join(sorted(known))}")
        return replace(self, **overrides)


#: The paper's section 3, to the letter.
PAPER = MesherParams(
    style="paper",
    alpha_threshold=129,          # paper: alpha > 128
    min_component_area=100.0,
    hull_tolerance=0.0,
    min_vertex_distance=0.0,
)

#: Sparse, never clipping, constrained: what we recommend for animation.
DEFAULT = MesherParams(
    style="default",
    alpha_threshold=8,
    min_component_area=0.0,
    hull_tolerance=0.08,
    min_contour_length=60.0,
    interior_dp_ratio=0.05,
    max_segment=80.0,
    border_distance=6.0,
    dedup_radius=24.0,
    min_vertex_distance=4.0,
    fill_ratio=0.3,
    min_angle=30.0,
    max_fill_vertices=30,
)

#: Preset name -> parameters.
PRESETS: dict[str, MesherParams] = {"default": DEFAULT, "paper": PAPER}
