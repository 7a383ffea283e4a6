"""How many rounds of batched re-solves :func:`jaxwalk.bifurcation.locate` plans and has run.

One round is one batched call of the cycle re-solve (every bracket of every
line at once). The plan is known in advance for the bisections (edges,
border collisions: the number of halvings to ``2 tol``) and bounded for the
regula falsi (``max_iter``, usually far fewer), so a progress bar's total is
set up front and corrected as the work ends sooner or goes on (an edge
followed past its grid interval).
"""

from __future__ import annotations

import numpy as np


class Rounds:
    """Counts :func:`jaxwalk.bifurcation.locate`'s rounds of batched solves on a progress bar (or nowhere);
    ``options``: its :class:`~jaxwalk.bifurcation.BifurcationOptions` (``tol``, ``max_iter``)."""

    def __init__(self, bar, signs, edge_rows, collision_rows, x: np.ndarray, options):
        self.bar = bar
        self.sign_left = (options.max_iter + 1) if signs else 0  # the last +1: the midpoints' solve
        bisections = lambda rows, a, b: (int(np.ceil(np.log2(max(max(abs(x[r[0], b(r)] - x[r[0], a(r)]) for r in rows)
                                                                      / (2 * options.tol), 1.0)))) if rows else 0)
        # edges: one more round to solve at the failed grid point
        self.edge_left = bisections(edge_rows, lambda r: r[1], lambda r: r[2]) + (1 if edge_rows else 0)
        self.collision_left = bisections(collision_rows, lambda r: r[1], lambda r: r[1] + 1)
        if bar is not None:
            bar.total = self.sign_left + self.edge_left + self.collision_left
            bar.refresh()

    def advance(self, signs: bool = False) -> None:
        if signs:
            self.sign_left -= 1
        if self.bar is not None:
            self.bar.update(1)

    def signs_done(self) -> None:
        """The regula falsi ended before ``max_iter``: its unused rounds leave the total."""
        if self.bar is not None and self.sign_left > 1:
            self.bar.total -= self.sign_left - 1
            self.bar.refresh()
        self.sign_left = min(self.sign_left, 1)

    def no_signs(self) -> None:
        """No sign change to locate after all (the collisions had none beside them)."""
        if self.bar is not None and self.sign_left > 0:
            self.bar.total -= self.sign_left
            self.bar.refresh()
        self.sign_left = 0

    def _planned_round(self, left: str) -> None:
        """One round of a bisection; past the plan (an edge moved on to the next interval) the total grows."""
        if getattr(self, left) > 0:
            setattr(self, left, getattr(self, left) - 1)
        elif self.bar is not None:
            self.bar.total += 1
        self.advance()

    def _planned_done(self, left: str) -> None:
        if self.bar is not None and getattr(self, left) > 0:
            self.bar.total -= getattr(self, left)
            self.bar.refresh()
        setattr(self, left, 0)

    def edge_round(self) -> None:
        self._planned_round("edge_left")

    def edges_done(self) -> None:
        self._planned_done("edge_left")

    def collision_round(self) -> None:
        self._planned_round("collision_left")

    def collisions_done(self) -> None:
        self._planned_done("collision_left")
