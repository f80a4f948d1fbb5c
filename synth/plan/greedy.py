"""Greedy randomized starts for the swap climb: 7-contact grasps built a contact at a time.

A start is built from the pool (:class:`synth.plan.climb.SwapPool`) in two steps:

1. Six contacts whose wrenches span as much volume as they can: the first at random, then each
   next one among the ``choice`` pool contacts whose wrench has the most length left once the
   span of those already taken is projected out (the volume of the parallelotope of the
   wrenches grows by that length), picked at random among them. This is Gram-Schmidt with
   pivoting, randomized as in a greedy randomized adaptive search (GRASP: Feo and Resende,
   "Greedy randomized adaptive search procedures", J. Global Optimization 6, 1995).
2. The seventh: the pool contact that gives the six the highest d* (the swap climb's exact
   screen, :meth:`~synth.plan.climb.SwapPool.screen`; every reading of the normals the
   surface model scores), when one makes a closure grasp at all.

Six wrenches that span R^6 well leave a seventh that balances them with forces of similar
size, which is what d* (the least contact force of the balancing set, Trinkle 1992) rewards:
such starts climb to better optima than the best of many random 7-subsets of the pool.
Contacts whose fingertips would overlap one already taken are never taken.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from synth.plan.climb import SwapPool

__all__ = ["CHOICE", "greedy_starts"]

#: Pool contacts a step picks among at random, those whose wrench has the most length left.
CHOICE = 64
#: Starts whose (n,) rows of lengths left are updated and ranked at a time, so that they stay in
#: the cache (250 starts over 2,000 contacts: 5.2 ms a step at once, 1.9 ms 64 at a time).
_ROWS = 64


def greedy_starts(swaps: SwapPool, rng: np.random.Generator, m: int, choice: int = CHOICE
                  ) -> NDArray[np.int64]:
    """Up to ``m`` 7-contact starts, as pool indices (see the module notes).

    Parameters
    ----------
    swaps : SwapPool
        The pool's wrench columns and fingertip clashes.
    rng : numpy.random.Generator
    m : int
        Starts built (side by side); those whose seventh contact makes no closure grasp are
        dropped.
    choice : int
        Contacts each of steps 2 to 6 picks among (1: the plain greedy, the most length left).

    Returns
    -------
    (m', 7) int
        Pool indices of the starts (m' <= m), in the order built.
    """
    X = swaps.columns[0].T  # (n, 6): the wrenches of the surface model's first reading
    n = len(X)
    if n < 7 or m < 1:
        return np.zeros((0, 7), np.int64)
    ar = np.arange(m)
    left = np.broadcast_to(np.einsum("nk,nk->n", X, X), (m, n)).copy()  # length^2 left
    basis = np.zeros((m, 6, 6))  # orthonormal rows spanning the contacts taken
    allowed = np.ones((m, n), bool)
    valid = np.ones(m, bool)
    chosen = np.zeros((m, 7), np.int64)
    blocks = [slice(s, s + _ROWS) for s in range(0, m, _ROWS)]
    for step in range(6):
        if step == 0:
            c = rng.choice(n, m, replace=m > n)
        else:
            q = min(choice, n - step)
            pick = rng.integers(0, q, m)
            most = np.empty((m, q), np.int64)
            for b in blocks:
                most[b] = np.argpartition(-np.where(allowed[b], left[b], -1.0), q - 1,
                                          axis=1)[:, :q]
            c = most[ar, pick]
            # fewer than q allowed contacts left (a small or crowded pool): then they are all
            # among the q, and the pick is drawn again among them
            for i in np.flatnonzero(~allowed[ar, c] & allowed.any(axis=1)).tolist():
                ok = most[i][allowed[i, most[i]]]
                c[i] = ok[rng.integers(0, len(ok))]
            valid &= allowed[ar, c]
        chosen[:, step] = c
        allowed[ar, c] = False
        x = X[c]
        if step:
            x = x - np.einsum("mj,mjk->mk", np.einsum("mjk,mk->mj", basis[:, :step], x),
                              basis[:, :step])
        u = x / np.maximum(np.linalg.norm(x, axis=1, keepdims=True), 1e-300)
        basis[:, step] = u
        for b in blocks:
            allowed[b] &= ~swaps.clash[c[b]]
            left[b] -= (u[b] @ X.T) ** 2
    chosen[:, 6] = chosen[:, 0]  # a placeholder: the screen replaces column 6
    d = swaps.screen(chosen, 6)
    best = np.argmax(d, axis=1)
    valid &= d[ar, best] > 0
    chosen[:, 6] = best
    return chosen[valid]
