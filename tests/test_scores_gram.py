"""The Gram certificate never changes a rank, and its null vectors are the SVD's."""

from __future__ import annotations

import numpy as np
import pytest

from synth import wrench_matrix
from synth.scores.gram import gram_inverse_factor, null_vector_m1, rank_of_balanced
from synth.scores.wrench import balance_rows, numerical_rank
from tests.scoring_cases import blob_contacts, cube_contacts


def _sphere_W(rng, n):
    P = rng.normal(size=(n, 3))
    P /= np.linalg.norm(P, axis=1, keepdims=True)
    return wrench_matrix(P, -P)  # every normal through the centre: moment block is round-off


def _cases(rng):
    Ws = [rng.normal(size=(6, n)) for n in (6, 7, 12, 20) for _ in range(20)]
    Ws += [wrench_matrix(*cube_contacts(rng, n)) for n in (7, 12) for _ in range(20)]
    Ws += [_sphere_W(rng, n) for n in (6, 7, 12) for _ in range(5)]
    for k in (1, 3, 5):  # exactly rank-deficient: rank k
        Ws += [rng.normal(size=(6, k)) @ rng.normal(size=(k, n)) for n in (7, 12)]
    near = rng.normal(size=(6, 12))
    U, S, Vt = np.linalg.svd(near, full_matrices=False)
    for s_min in (1e-3, 1e-6, 1e-8, 1e-10, 1e-12):  # around and beyond the certificate
        S2 = S.copy()
        S2[-1] = s_min * S[0]
        Ws.append((U * S2) @ Vt)
    return Ws


@pytest.mark.parametrize("n", [7, 12])
def test_rank_matches_numerical_rank(n):
    rng = np.random.default_rng(n)
    Ws = [W for W in _cases(rng)]
    for W in Ws:
        Wb, _ = balance_rows(W[None])
        assert rank_of_balanced(Wb)[0] == numerical_rank(W)


def test_certificate_bounds_the_condition_number():
    rng = np.random.default_rng(3)
    Ws = _cases(rng)
    cert = []
    for W in Ws:
        X, c = gram_inverse_factor(W[None])
        S = np.linalg.svd(W, compute_uv=False)
        if c[0]:
            assert S[-1] / S[0] >= 0.99e-5 and S.size == W.shape[0]
        cert.append(bool(c[0]))
    assert any(cert) and not all(cert)


def test_planar_rank():
    rng = np.random.default_rng(4)
    Ws = [wrench_matrix(*blob_contacts(rng, n, 2, 0.5)) for n in (3, 4, 6) for _ in range(10)]
    Ws.append(np.zeros((3, 4)))
    for W in Ws:
        Wb, _ = balance_rows(W[None])
        assert rank_of_balanced(Wb)[0] == numerical_rank(W)


def test_null_vector_matches_svd():
    rng = np.random.default_rng(5)
    W = np.stack([wrench_matrix(*cube_contacts(rng, 7)) for _ in range(50)]
                 + [rng.normal(size=(6, 7)) for _ in range(50)])
    Wb, _ = balance_rows(W)
    X, cert = gram_inverse_factor(Wb)
    assert cert.sum() > 60  # cube grasps with 7 contacts are often rank deficient
    Wb, X = Wb[cert], X[cert]
    v = null_vector_m1(Wb, X)
    ref = np.linalg.svd(Wb)[2][:, -1, :]
    sign = np.sign(np.einsum("bi,bi->b", v, ref))
    assert np.abs(v - sign[:, None] * ref).max() < 1e-12
    assert np.abs(np.einsum("bij,bj->bi", Wb, v)).max() < 1e-13


def test_vectorised_cholesky_and_inverse_match_lapack():
    from synth.scores.gram import _cholesky, _tri_inverse

    rng = np.random.default_rng(6)
    W = rng.normal(size=(30, 6, 9))
    G = W @ np.transpose(W, (0, 2, 1))
    ok = np.ones(30, dtype=bool)
    L = _cholesky(G, ok)
    assert ok.all()
    assert np.allclose(L, np.linalg.cholesky(G), rtol=1e-12, atol=1e-12)
    assert np.allclose(_tri_inverse(L), np.linalg.inv(L), rtol=1e-10, atol=1e-10)
    G[3] = 0.0  # not positive definite: flagged, no exception
    ok = np.ones(30, dtype=bool)
    _cholesky(G, ok)
    assert not ok[3] and ok.sum() == 29


def test_mixed_batch_uses_the_fallback_factor():
    rng = np.random.default_rng(7)
    good = rng.normal(size=(5, 6, 12))
    bad = rng.normal(size=(2, 6, 3)) @ rng.normal(size=(2, 3, 12))  # rank 3
    W = np.concatenate([good, bad])
    X, cert = gram_inverse_factor(W)
    assert cert.tolist() == [True] * 5 + [False] * 2
    assert rank_of_balanced(W, cert).tolist() == [6] * 5 + [3] * 2


def test_certificate_threshold_stays_above_the_rank_tolerance():
    # the Gram certificate may only vouch for full rank where the SVD test surely agrees
    from synth.scores.gram import GRAM_COND2_MAX
    from synth.tolerances import RANK_RTOL

    assert GRAM_COND2_MAX ** -0.5 >= 10 * RANK_RTOL
