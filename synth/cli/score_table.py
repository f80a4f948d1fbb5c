"""Scores of a candidate table (``synth score``): d* of every valid candidate in vectorised
batches, and why the failing ones fail.

Every valid candidate is scored in batches (one per shape and friction coefficient); a
malformed one keeps its message. The motion a failing grasp leaves free, and the contacts it
can still squeeze, are worked out only for the rows asked (:func:`explain`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["Scores", "score_table", "explain", "format_table"]


@dataclass(frozen=True)
class Scores:
    """Scores of every candidate of a :class:`synth.grasps.CandidateTable`, in file order.

    Attributes
    ----------
    names : tuple of str
    contacts : (B,) int
    mu : (B,) float
        Friction coefficient used (the candidate's own, else the default).
    d_star : (B,) float
    closure : (B,) str
        ``"form"``, ``"frictional form"`` or ``"force"``; ``""`` for malformed candidates.
    rank : (B,) int
    valid : (B,) bool
        False for malformed candidates (see ``errors``).
    errors : tuple of (int, str)
    """

    names: tuple[str, ...]
    contacts: NDArray[np.int64]
    mu: NDArray[np.float64]
    d_star: NDArray[np.float64]
    closure: NDArray[np.str_]
    rank: NDArray[np.int64]
    valid: NDArray[np.bool_]
    errors: tuple[tuple[int, str], ...]

    def order(self) -> NDArray[np.int64]:
        """Valid candidates best first: closure before non-closure, then by d* as the table
        prints it (:func:`synth.plan.ranking.shown_d_star`), then by position in the file."""
        from synth.plan.ranking import shown_d_star

        idx = np.flatnonzero(self.valid)
        is_closure = self.closure[idx] != "force"
        printed = np.array([shown_d_star(d) for d in self.d_star[idx].tolist()])
        return idx[np.lexsort((idx, -printed, ~is_closure))]


def _wrenches(P: NDArray[np.float64], N: NDArray[np.float64]) -> NDArray[np.float64]:
    """Wrench matrices (b, m, k) of contacts (b, k, d), moments about each centroid."""
    R = P - P.mean(axis=1, keepdims=True)
    if P.shape[2] == 3:
        tau = np.cross(R, N)
    else:
        tau = (R[..., 0] * N[..., 1] - R[..., 1] * N[..., 0])[..., None]
    return np.concatenate([N, tau], axis=2).swapaxes(1, 2)


def score_table(table: Any, mu: float = 0.0, edges: int = 8, torsion: float = 0.0) -> Scores:
    """Score every valid candidate of a :class:`synth.grasps.CandidateTable`.

    Parameters
    ----------
    table : CandidateTable
    mu : float
        Friction coefficient of candidates that give none.
    edges : int
        Edges of each linearised friction cone.
    torsion : float
        Torsional coefficient of soft contacts (0: point contacts); planar candidates are
        refused with it.

    Returns
    -------
    Scores
    """
    from synth.grasps import min_contacts
    from synth.scores import form_closure_batch, frictional_form_closure
    from synth.scores.friction_batch import frictional_form_closure_batch

    B = len(table)
    d = np.zeros(B)
    closure = np.full(B, "", dtype="<U15")
    rank = np.zeros(B, np.int64)
    k_all = np.zeros(B, np.int64)
    mu_used = np.where(np.isnan(table.mu), mu, table.mu)
    valid = np.zeros(B, bool)
    errors = dict(table.errors)
    for g in table.groups:
        b, k, dim = g.points.shape
        k_all[g.index] = k
        for m_val in np.unique(mu_used[g.index]):
            sel = mu_used[g.index] == m_val
            idx = g.index[sel]
            need = 2 if torsion > 0 and dim == 3 else min_contacts(dim, m_val)
            if k < need or (torsion > 0 and dim == 2):
                kind = "with friction" if m_val > 0 else "without friction (use --mu for friction)"
                space = "in space" if dim == 3 else "in the plane"
                for i in idx.tolist():
                    name = f" ({table.names[i]})" if not table.names[i].startswith("#") else ""
                    errors[i] = (f"{table.source}: candidate {i}{name}: " + (
                        "--torsion needs contacts in space, got planar ones" if dim == 2
                        and torsion > 0 else f"{k} contacts, but at least {need} are needed "
                        f"{space} {kind}"))
                continue
            P, N = g.points[sel], g.normals[sel]
            if torsion > 0:
                res = frictional_form_closure_batch(P, N, float(m_val), edges=edges,
                                                    torsion=torsion)
                d[idx], rank[idx] = res.d_star, res.rank
                closure[idx] = np.where(res.closure, "frictional form", "force")
            elif m_val == 0:
                res = form_closure_batch(_wrenches(P, N))
                d[idx], rank[idx] = res.d_star, res.rank
                closure[idx] = np.where(res.closure, "form", "force")
            elif dim == 3:
                res = frictional_form_closure_batch(P, N, float(m_val), edges=edges)
                d[idx], rank[idx] = res.d_star, res.rank
                closure[idx] = np.where(res.closure, "frictional form", "force")
            else:  # planar with friction: small problems, one LP each
                for j, i in enumerate(idx.tolist()):
                    r = frictional_form_closure(P[j], N[j], float(m_val), edges=edges)
                    d[i], rank[i], closure[i] = r.d_star, r.rank, r.closure
            valid[idx] = True
    return Scores(tuple(table.names), k_all, mu_used, d, closure, rank, valid,
                  tuple(sorted(errors.items())))


def explain(table: Any, scores: Scores, rows: NDArray[np.int64], edges: int = 8,
            torsion: float = 0.0) -> dict[int, tuple[str | None, list[int] | None]]:
    """For the failing candidates among ``rows``: the motion left free, in words, and the
    contacts that can still be squeezed without bound (Trinkle's strong force closure, with
    friction where the candidate has it)."""
    from synth.scores import form_closure, squeezable_contacts
    from synth.scores.friction import frictional_form_closure, frictional_squeezable

    where = {}
    for g in table.groups:
        for j, i in enumerate(g.index.tolist()):
            where[i] = (g, j)
    out: dict[int, tuple[str | None, list[int] | None]] = {}
    for i in rows.tolist():
        if scores.closure[i] != "force":
            continue
        g, j = where[i]
        P, N = g.points[j], g.normals[j]
        m = float(scores.mu[i])
        if m == 0 and torsion == 0:
            W = _wrenches(P[None], N[None])[0]
            words = form_closure(W).escape_words
            squeeze = squeezable_contacts(W)
        else:
            words = frictional_form_closure(P, N, m, edges=edges, torsion=torsion).escape_words
            squeeze = frictional_squeezable(P, N, m, edges=edges, torsion=torsion).squeezable
        out[i] = (words, np.flatnonzero(squeeze).tolist())
    return out


def format_table(scores: Scores, rows: NDArray[np.int64],
                 why: dict[int, tuple[str | None, list[int] | None]]) -> str:
    """A plain-text table of the given rows, in the given order."""
    name_w = max([len("name")] + [len(scores.names[i]) for i in rows.tolist()])
    lines = [f"{'#':>4}  {'name':<{name_w}}  {'k':>3}  {'mu':>5}  {'d*':>8}  {'closure':<15}  "
             f"{'rank':>4}  why not"]
    for n, i in enumerate(rows.tolist(), 1):
        words, squeeze = why.get(i, (None, None))
        note = words or ""
        if squeeze:
            note += f" (contacts {','.join(map(str, squeeze))} can still be squeezed)"
        lines.append(
            f"{n:>4}  {scores.names[i]:<{name_w}}  {scores.contacts[i]:>3}  {scores.mu[i]:>5.2f}  "
            f"{scores.d_star[i]:>8.5f}  {scores.closure[i]:<15}  {scores.rank[i]:>4}  "
            f"{note}".rstrip()
        )
    return "\n".join(lines)
