"""Every numerical tolerance synth uses, in one documented place.

All values are dimensionless unless stated. Change them here, never inline.

Scorer (Trinkle's linear programs)
----------------------------------
RANK_RTOL
    A singular value ``s`` of a wrench matrix counts towards its rank when
    ``s > RANK_RTOL * s_max``. Moment rows are first scaled to the size of the force rows (see
    :func:`synth.scores.wrench.balance_rows`) so the test does not depend on units.
    1e-6 is set by the inputs synth really gets: STL files store float32 coordinates, so
    normals resolved on a mesh are exact only to about 1e-7 rad, and on a surface of revolution
    that noise alone makes a moment about the axis of relative size ~1e-7 (measured on
    ``meshes/cylinder.stl``: with 1e-9, one random contact set in six was wrongly called form
    closure). A real grasp this close to rank loss resists its weakest motion a million times
    less than its strongest, which no hand can exploit; the planner's own conditioning filter
    (1e-3) is far stricter still.
D_STAR_TOL
    d* is reported as exactly 0 when the LP optimum is at most this. A grasp is form closure
    when ``d* > D_STAR_TOL`` and the wrench matrix has full row rank. 1e-9 is above the
    LP solvers' feasibility tolerance (HiGHS: 1e-7 primal feasibility on a problem of
    scale 1 is an absolute bound on residuals, and our optimum is recomputed exactly from the
    optimal basis), so a reported positive d* is a real positive margin.
MOMENT_NOISE_RTOL
    Before the rank test the moment rows of W are rescaled to the size of the force rows (so
    the test does not depend on the length unit); a moment block whose norm is below this
    fraction of the force block's is taken as round-off (all normals through one point, as on
    a sphere) and left unscaled. 1e-9 leaves any real part, from nanometres to kilometres in
    any unit, correctly scaled, and sits well above the 1e-16 noise of ``r x n``.
LP_FEAS_TOL
    Primal and dual feasibility tolerance used to accept the batched simplex's certificate.
"""

from __future__ import annotations

__all__ = ["RANK_RTOL", "D_STAR_TOL", "LP_FEAS_TOL", "MOMENT_NOISE_RTOL", "NORMAL_NORM_TOL"]

RANK_RTOL: float = 1e-6
D_STAR_TOL: float = 1e-9
LP_FEAS_TOL: float = 1e-9
MOMENT_NOISE_RTOL: float = 1e-9
#: A supplied contact normal is accepted when its length is above this (it is then normalised).
NORMAL_NORM_TOL: float = 1e-12
