"""Reference cases with known answers, shared by the scorer tests.

Trinkle (1992) Examples 1-3 as functions of their parameters, the exact d* derived by hand
for each, and generators of random contact sets.
"""

from __future__ import annotations

import numpy as np

# --- Example 1: rectangle, four frictionless contacts (Table 1) -------------------------------
TABLE1 = [  # alpha, printed d*, printed class
    (1.04, 0.0, "force"), (1.06, 0.020, "form"), (1.1, 0.097, "form"), (1.2, 0.300, "form"),
    (1.3, 0.267, "form"), (1.4, 0.170, "form"), (1.5, 0.071, "form"), (1.56, 0.010, "form"),
    (1.5707, 0.0, "force"), (1.58, 0.0, "force"),
]


def example1_W(alpha: float, length: float = 1.0) -> np.ndarray:
    """Trinkle's Example 1 wrench matrix (moments about the upper right corner; the paper's
    length l is ``length``)."""
    return np.array(
        [[0, 0, 1, -np.cos(alpha)], [1, 1, 0, -np.sin(alpha)], [-length, 0, 7 * length / 4, 0]],
        dtype=float,
    )


def example1_exact(alpha: float) -> float:
    """Exact d*: the null space is spanned by (7/4 cos a, sin a - 7/4 cos a, cos a, 1)."""
    c = np.array([7 / 4 * np.cos(alpha), np.sin(alpha) - 7 / 4 * np.cos(alpha), np.cos(alpha), 1.0])
    return float(c.min() / c.max()) if c.min() > 0 else 0.0


# --- Example 2: triangle, frictional third contact (Table 2) ----------------------------------
TABLE2 = [  # l3, printed d*, printed class, printed c1, printed c2
    (-0.001, 0.0, "force", None, None), (0.001, 0.001, "frictional form", 0.001, 1.0),
    (0.1, 0.104, "frictional form", 0.104, 0.932), (0.3, 0.311, "frictional form", 0.311, 0.725),
    (0.5, 0.518, "frictional form", 0.518, 0.518), (0.7, 0.311, "frictional form", 0.725, 0.311),
    (0.9, 0.104, "frictional form", 0.932, 0.104), (0.999, 0.001, "frictional form", 1.0, 0.001),
    (1.001, 0.0, "force", None, None),
]
BETA = np.radians(15.0)


def example2_W(l3: float, l1: float = 0.0, l2: float = 1.0, beta: float = BETA) -> np.ndarray:
    """Eq. (20): columns n1, n2, n3 and the tangential column of contact 3 (free)."""
    return np.array(
        [
            [1, 1, -np.cos(beta), -np.sin(beta)],
            [0, 0, np.sin(beta), -np.cos(beta)],
            [-l1, -l2, l3 / np.cos(beta), 0],
        ],
        dtype=float,
    )


def example2_exact(l3: float, beta: float = BETA) -> tuple[float, np.ndarray]:
    """Exact d* and null vector: c = t ((1 - l3)/cos b, l3/cos b, 1, tan b)."""
    c = np.array([(1 - l3) / np.cos(beta), l3 / np.cos(beta), 1.0, np.tan(beta)])
    if min(c[:3]) <= 0:
        return 0.0, np.zeros(4)
    c = c / np.abs(c).max()
    return float(c[:3].min()), c


# --- Example 3: square, strong force closure (Table 3) ----------------------------------------
TABLE3 = [-1.001, -1.0, -0.5, -0.0, 0.4, 0.7, 1.0, 1.001]


def example3_W(a: float) -> np.ndarray:
    """Eq. (25)."""
    return np.array([[0, -1, -1, 1], [1, 0, 0, 0], [0, -1, 1, a]], dtype=float)


# --- random contact sets ----------------------------------------------------------------------
def cube_contacts(rng: np.random.Generator, n: int, size: float = 1.0):
    """n random points on the faces of an axis-aligned cube of edge ``size``, inward normals."""
    ax = rng.integers(0, 3, n)
    sg = rng.choice([-1.0, 1.0], n)
    P = rng.uniform(-size / 2, size / 2, (n, 3))
    P[np.arange(n), ax] = sg * size / 2
    N = np.zeros((n, 3))
    N[np.arange(n), ax] = -sg
    return P, N


def blob_contacts(rng: np.random.Generator, n: int, dim: int = 3, spread: float = 0.8):
    """Points on a unit sphere with normals roughly towards the centre (many form closures)."""
    P = rng.normal(size=(n, dim))
    P /= np.linalg.norm(P, axis=1, keepdims=True)
    N = -P + spread * rng.normal(size=(n, dim))
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    return P, N


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    """A uniformly random 3-D rotation matrix."""
    Q, R = np.linalg.qr(rng.normal(size=(3, 3)))
    Q = Q * np.sign(np.diag(R))
    if np.linalg.det(Q) < 0:
        Q[:, 0] = -Q[:, 0]
    return Q
