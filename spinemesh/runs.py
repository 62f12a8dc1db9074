"""What every whole-project run reports: its items' statuses, its problems, its exit status.

``upgrade`` (:class:`spinemesh.upgrade.Result`) and ``weights``
(:class:`spinemesh.rig.run.WeightResult`) both count their attachments by status and end with
the same exit status when something failed.
"""

from __future__ import annotations

from collections import Counter

#: Exit status when the input or options give nothing to work on: a bad value, a folder
#: without a skeleton, ``--only`` matching nothing (0: all that was asked was done, deliberate
#: skips included).
EXIT_BAD_INPUT = 2

#: Exit status of a run in which some attachments or files could not be done.
EXIT_PARTIAL = 3


class RunSummary:
    """Mixin for a run's result: ``_items()`` yields everything that has a ``status``, and
    ``errors`` lists the problems that stopped a whole file."""

    errors: list[str]

    def _items(self):
        raise NotImplementedError

    @property
    def partial(self) -> bool:
        """True when something failed: an item, or a whole file."""
        return bool(self.errors) or any(item.status == "failed" for item in self._items())

    def counts(self) -> dict[str, int]:
        """Items by status, in the order statuses first occur."""
        return dict(Counter(item.status for item in self._items()))
