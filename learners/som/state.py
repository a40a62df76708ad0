"""The learned state of the visuomotor map: its three arrays and what is derived from them.

Neuron r of the lattice holds w_r (where it sits in input space), θ_r (the joint angles that
reach there) and A_r (a local linear map, ≈ ∂θ/∂u): ``w`` (N, D), ``theta`` (N, J), ``A``
(N, J, D), N = prod(lattice), neurons in C order. Derived from w: |w_r|² (the winner search),
the bounding spheres of lattice blocks (the pruned search of large lattices) and a version that
counts the changes of w, so that a winner found for a target stays valid until w moves.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from learners.som import kernels

#: The memo of no winner: (target's bytes, version, winner).
_NO_WINNER: tuple[bytes, int, int] = (b"", -1, -1)


@dataclass(eq=False)
class MapState:
    """w, θ, A and what is derived from them (module docstring).

    ``block_centre`` (B, D) and ``block_radius`` (B,) are the bounding spheres of the lattice's
    blocks when the winner search is pruned, else empty; ``shape`` (3,) is the lattice padded
    with leading 1s to the kernels' three axes.
    """

    w: np.ndarray  # (N, D)
    theta: np.ndarray  # (N, J)
    A: np.ndarray  # (N, J, D)
    shape: np.ndarray  # (3,) int64
    block_centre: np.ndarray  # (B, D) or (0, 1)
    block_radius: np.ndarray  # (B,) or (0,)
    w2: np.ndarray = field(init=False)  # (N,) |w_r|²
    version: int = 0
    last_winner: tuple[bytes, int, int] = _NO_WINNER

    def __post_init__(self) -> None:
        self.w_changed()

    @property
    def pruned(self) -> bool:
        """Whether the winner search is pruned by the blocks' bounding spheres."""
        return len(self.block_radius) > 0

    def w_changed(self) -> None:
        """Derive |w_r|² and the block spheres again after w changed outside the learning step,
        and forget the remembered winner."""
        self.w2 = np.einsum("nd,nd->n", self.w, self.w)  # (N,)
        if self.pruned:
            kernels.refresh_blocks(self.w, self.shape, self.block_centre, self.block_radius)
        self.version += 1
        self.last_winner = _NO_WINNER

    def remember_winner(self, u: np.ndarray, s: int) -> None:
        """s is the winner for target u while w does not change."""
        self.last_winner = (u.tobytes(), self.version, s)

    def remembered_winner(self, u: np.ndarray) -> int:
        """The winner remembered for target u if w has not changed since, else −1."""
        memo = self.last_winner
        return memo[2] if memo[1] == self.version and memo[0] == u.tobytes() else -1

    def copy(self) -> MapState:
        """An independent copy (the derived data recomputed, the memo forgotten)."""
        return MapState(
            self.w.copy(), self.theta.copy(), self.A.copy(), self.shape,
            self.block_centre.copy(), self.block_radius.copy(), self.version,
        )  # fmt: skip
