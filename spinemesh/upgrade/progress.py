"""What an upgrade tells while it runs: each phase's work as it becomes known, then its steps.

The phases, in the order a project goes through them: ``read`` (skeletons read and planned),
``mesh`` (unique images meshed), ``weights`` (new meshes bound to bones, ``--weights auto``),
``write`` (skeletons written) and ``pack`` (atlases packed, ``--pack``: placements tried
and pages written). A library run goes through them project by project, and
plans the next projects while the workers mesh, so several phases may be under way at once;
their totals grow as projects are planned. The command line shows one bar per phase
(:mod:`spinemesh.cli.upgrade`); the default tells nothing.
"""

from __future__ import annotations

PHASES = ("read", "mesh", "weights", "write", "pack")

#: The phases whose steps are work (an atlas's page texels weighed by what each step costs a
#: texel, :mod:`spinemesh.pack.progress`), not things: shown done in percent.
IN_WORK = ("pack",)


class Progress:
    """Receives a run's progress; this base class ignores it (the Python API's default)."""

    def add(self, phase: str, steps: int, project: str | None = None) -> None:
        """``steps`` more steps of ``phase`` (one of :data:`PHASES`) are known; ``project``: the
        project they belong to, where a library run works on it ahead of the one it writes (the
        meshing of the projects planned ahead), else None: the project written (:meth:`project`)."""

    def advance(self, phase: str, steps: int = 1) -> None:
        """``steps`` steps of ``phase`` are done."""

    def step(self, phase: str, what: str, item: str = "") -> None:
        """What ``phase`` does now, in words, to ``item`` (packing: its step, to an atlas of the
        project written)."""

    def project(self, name: str) -> None:
        """A library run now writes the project ``name`` (its path under the library): the steps of
        the phases not added for another project are its own."""


#: The progress of a run that tells nobody.
SILENT = Progress()
