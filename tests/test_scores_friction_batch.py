"""The batched frictional scorer agrees with the single HiGHS LP."""

from __future__ import annotations

import numpy as np
import pytest

from synth import (
    InputError,
    form_closure_batch,
    frictional_form_closure,
    frictional_form_closure_batch,
    wrench_matrix,
)
from tests.scoring_cases import blob_contacts

#: every test here runs with both simplex routes (see tests/conftest.py)
pytestmark = pytest.mark.usefixtures("pivot_route")


@pytest.mark.parametrize("k, mu, edges", [(3, 0.5, 8), (4, 0.3, 6), (6, 0.8, 8), (7, 0.05, 4)])
def test_agrees_with_single_lp(k, mu, edges):
    rng = np.random.default_rng(10 * k + edges)
    PN = [blob_contacts(rng, k, 3, 0.9) for _ in range(80)]
    P = np.array([p for p, _ in PN])
    N = np.array([n for _, n in PN])
    res = frictional_form_closure_batch(P, N, mu, edges=edges)
    for i in range(len(P)):
        ref = frictional_form_closure(P[i], N[i], mu, edges=edges)
        assert res.d_star[i] == pytest.approx(ref.d_star, abs=1e-7)
        assert bool(res.closure[i]) == ref.is_closure
        assert res.rank[i] == ref.rank
    assert res.closure.any() or k == 3


def test_small_mu_approaches_frictionless():
    rng = np.random.default_rng(1)
    PN = [blob_contacts(rng, 8, 3, 0.5) for _ in range(40)]
    P = np.array([p for p, _ in PN])
    N = np.array([n for _, n in PN])
    fr = frictional_form_closure_batch(P, N, 1e-9)
    fl = form_closure_batch(np.stack([wrench_matrix(p, n) for p, n in zip(P, N, strict=True)]))
    assert np.allclose(fr.d_star, fl.d_star, atol=1e-6)


def test_bad_input():
    with pytest.raises(InputError, match="mu"):
        frictional_form_closure_batch(np.zeros((1, 3, 3)), np.ones((1, 3, 3)), 0.0)
    with pytest.raises(InputError, match="shape"):
        frictional_form_closure_batch(np.zeros((3, 3)), np.ones((3, 3)), 0.5)
    assert len(frictional_form_closure_batch(np.zeros((0, 3, 3)), np.ones((0, 3, 3)), 0.5)) == 0
