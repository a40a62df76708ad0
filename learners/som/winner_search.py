"""The winner search of the compiled path: s = argmin_r |w_r|² − 2 w_r·u, by a plain scan, or,
on large ordered maps, by scanning only the lattice blocks that can hold the winner.

Blocks are BLOCK³ neurons of the (padded 3-D) lattice; each keeps a centre and a radius in
input space such that every w_r of the block lies within radius of the centre. A block whose
lower bound (|u − centre| − radius)² exceeds the best |u − w_r|² found cannot hold the
winner. The result is the plain scan's neuron, ties to the lower index.
"""

from __future__ import annotations

import numpy as np

from learners.compiled import jit as _jit

#: Edge of the lattice blocks (neurons), and the relative slack that keeps the bounds
#: conservative under rounding (scores carry ~1e-16 relative error).
BLOCK = 4
SLACK = 1e-9
#: Above this fraction of blocks left to scan, the plain scan (contiguous memory) is faster.
PRUNED_FRACTION = 0.25


@_jit
def winner(w: np.ndarray, w2: np.ndarray, u: np.ndarray) -> int:
    """argmin_r |w_r|² − 2 w_r·u over (N, D) w, (N,) w2, (D,) u."""
    best, best_score = 0, np.inf
    for n in range(w.shape[0]):
        dot = 0.0
        for d in range(w.shape[1]):
            dot += w[n, d] * u[d]
        score = w2[n] - 2.0 * dot
        if score < best_score:
            best, best_score = n, score
    return best


@_jit
def refresh_blocks(
    w: np.ndarray, shape: np.ndarray, centre: np.ndarray, radius: np.ndarray
) -> None:
    """Centre (mean w) and radius (largest |w − centre|) of every block of BLOCK³ neurons."""
    n0, n1, n2 = shape[0], shape[1], shape[2]
    b0, b1, b2 = (n0 + BLOCK - 1) // BLOCK, (n1 + BLOCK - 1) // BLOCK, (n2 + BLOCK - 1) // BLOCK
    D = w.shape[1]
    for p in range(b0):
        for q in range(b1):
            for m in range(b2):
                b = (p * b1 + q) * b2 + m
                count = 0
                for d in range(D):
                    centre[b, d] = 0.0
                for i in range(p * BLOCK, min(p * BLOCK + BLOCK, n0)):
                    for j in range(q * BLOCK, min(q * BLOCK + BLOCK, n1)):
                        for k in range(m * BLOCK, min(m * BLOCK + BLOCK, n2)):
                            r = (i * n1 + j) * n2 + k
                            count += 1
                            for d in range(D):
                                centre[b, d] += w[r, d]
                for d in range(D):
                    centre[b, d] /= count
                far = 0.0
                for i in range(p * BLOCK, min(p * BLOCK + BLOCK, n0)):
                    for j in range(q * BLOCK, min(q * BLOCK + BLOCK, n1)):
                        for k in range(m * BLOCK, min(m * BLOCK + BLOCK, n2)):
                            r = (i * n1 + j) * n2 + k
                            d2 = 0.0
                            for d in range(D):
                                d2 += (w[r, d] - centre[b, d]) ** 2
                            far = max(far, d2)
                radius[b] = np.sqrt(far) * (1.0 + SLACK) + SLACK


@_jit
def block_of(r: int, shape: np.ndarray) -> int:
    """The block holding neuron r."""
    n1, n2 = shape[1], shape[2]
    b1, b2 = (n1 + BLOCK - 1) // BLOCK, (n2 + BLOCK - 1) // BLOCK
    i, j, k = r // (n1 * n2), r // n2 % n1, r % n2
    return ((i // BLOCK) * b1 + j // BLOCK) * b2 + k // BLOCK


@_jit
def _scan_block(
    b: int, w: np.ndarray, w2: np.ndarray, u: np.ndarray, shape: np.ndarray, best: int,
    best_score: float,
) -> tuple[int, float]:  # fmt: skip
    """The winner's scan over the neurons of block b, continuing from (best, best_score);
    ties go to the lower index, as in :func:`winner`."""
    n0, n1, n2 = shape[0], shape[1], shape[2]
    b1, b2 = (n1 + BLOCK - 1) // BLOCK, (n2 + BLOCK - 1) // BLOCK
    p, q, m = b // (b1 * b2), b // b2 % b1, b % b2
    for i in range(p * BLOCK, min(p * BLOCK + BLOCK, n0)):
        for j in range(q * BLOCK, min(q * BLOCK + BLOCK, n1)):
            for k in range(m * BLOCK, min(m * BLOCK + BLOCK, n2)):
                r = (i * n1 + j) * n2 + k
                dot = 0.0
                for d in range(w.shape[1]):
                    dot += w[r, d] * u[d]
                score = w2[r] - 2.0 * dot
                if score < best_score or (score == best_score and r < best):
                    best, best_score = r, score
    return best, best_score


@_jit
def winner_pruned(
    w: np.ndarray, w2: np.ndarray, u: np.ndarray, shape: np.ndarray, centre: np.ndarray,
    radius: np.ndarray,
) -> int:  # fmt: skip
    """The same neuron as :func:`winner`, scanning only the blocks that can hold it: a block
    whose lower bound (|u − centre| − radius)² exceeds the best |u − w_r|² found is skipped
    (the plain scan when that would skip less than 1 − PRUNED_FRACTION of the blocks)."""
    nb, D = len(radius), w.shape[1]
    u2 = 0.0
    for d in range(D):
        u2 += u[d] * u[d]
    bound = np.empty(nb)
    first, first_bound = 0, np.inf
    for b in range(nb):
        d2 = 0.0
        for d in range(D):
            d2 += (u[d] - centre[b, d]) ** 2
        gap = max(np.sqrt(d2) - radius[b], 0.0)
        bound[b] = gap * gap
        if bound[b] < first_bound:
            first, first_bound = b, bound[b]
    best, best_score = _scan_block(first, w, w2, u, shape, w.shape[0], np.inf)
    limit = best_score + u2 + SLACK * (u2 + abs(best_score) + 1.0)  # ≥ best |u − w_r|²
    if np.sum(bound <= limit) > nb * PRUNED_FRACTION:  # little to skip (an unordered map)
        return winner(w, w2, u)
    for b in range(nb):
        limit = best_score + u2 + SLACK * (u2 + abs(best_score) + 1.0)
        if b != first and bound[b] <= limit:
            best, best_score = _scan_block(b, w, w2, u, shape, best, best_score)
    return best
