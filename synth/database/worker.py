"""What runs on a worker: plan one mesh file and pack the result for the database writer.

The database calls the planner through one function, ``plan_mesh_file(path, params) -> dict``,
found by :func:`resolve_planner`:

* by default ``synth.plan:plan_mesh_file`` (imported lazily, on the worker);
* or the ``"module:function"`` named by the environment variable ``SYNTH_DB_PLANNER`` (or the
  ``--planner`` option of ``synth db build``). This is the plug-in point for custom planners: any
  importable function with that signature that returns the planner's JSON document (format
  ``synth.grasps`` version 1) works, on local workers and on Dask workers alike (the parent
  resolves the name once and passes it with every task, so workers need the module importable,
  not the environment variable).

A planner must be deterministic given ``params`` (notably ``seed`` and the evaluation budget
``evals``): that is what makes a database identical whatever the engine and the number of workers.
"""

from __future__ import annotations

import importlib
import json
import math
import os
import signal
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from synth.database.schema import canonical_json, pack_array
from synth.errors import InputError, MeshError, SynthError

__all__ = [
    "PLANNER_ENV",
    "DEFAULT_PLANNER",
    "PlanOutcome",
    "GRIPPER_GRASP_COLUMNS",
    "resolve_planner",
    "load_planner",
    "plan_one",
    "run_one",
    "crashed",
    "mesh_report",
]

PLANNER_ENV = "SYNTH_DB_PLANNER"
DEFAULT_PLANNER = "synth.plan:plan_mesh_file"

_GRASP_COLUMNS = (
    "rank", "d_star", "closure", "conditioning", "epsilon", "n_contacts", "points", "normals",
    "features", "regions", "n_fingers", "tip_centers", "tip_radius", "approach", "body_length",
    "body_radius", "tolerance", "contact_regions", "sim", "squeeze_per_weight",
    "least_squeeze", "margin",
)  # fmt: skip
#: Columns of ``gripper_grasps`` rows, for documents of format ``synth.gripper_grasps``.
GRIPPER_GRASP_COLUMNS = (
    "rank", "gripper", "pose", "tcp", "width", "points", "normals", "squeeze_per_weight",
    "least_squeeze", "margin", "mu_min", "epsilon", "d_star", "sim",
)  # fmt: skip
#: Document formats a planner may return, and the table their grasps go to.
_FORMATS = {"synth.grasps": "grasps", "synth.gripper_grasps": "gripper_grasps"}


class _Timeout(BaseException):
    """Raised inside a task when its time limit is reached.

    A ``BaseException``, so that a planner's ``except Exception`` (a mesh loader turning any
    error into "cannot be read") lets it through.
    """


@dataclass(frozen=True)
class PlanOutcome:
    """The packed result of planning one mesh, ready for one database transaction.

    Attributes
    ----------
    path : str
        The mesh file.
    ok : bool
        True if grasps were found.
    error_kind, error : str or None
        Failure category and reason when ``ok`` is False.
    units : str or None
        Units the planner reported.
    length : float or None
        Characteristic length the planner reported.
    planner_params : str or None
        JSON of the planner's full parameter set.
    synth_version : str or None
        Version reported by the planner.
    rows : tuple of tuple
        One tuple per grasp, in the column order of ``GRASP_COLUMNS`` (rank first).
    plan_s : float or None
        Planner-reported time.
    worker_s : float
        Wall time of the task on the worker.
    report : str or None
        What loading did to the mesh, for ``meshes.mesh_report``: canonical JSON of the
        document's ``mesh`` object without ``path`` and ``sha256`` (see :func:`mesh_report`);
        None when the planner returned no document or no ``mesh`` object.
    table : str
        Where ``rows`` go: ``"grasps"`` (columns ``GRASP_COLUMNS``) or ``"gripper_grasps"``
        (columns ``GRIPPER_GRASP_COLUMNS``, from a ``synth.gripper_grasps`` document).
    """

    path: str
    ok: bool
    error_kind: str | None
    error: str | None
    units: str | None
    length: float | None
    planner_params: str | None
    synth_version: str | None
    rows: tuple[tuple[Any, ...], ...]
    plan_s: float | None
    worker_s: float
    report: str | None = None
    table: str = "grasps"

    GRASP_COLUMNS = _GRASP_COLUMNS

    @property
    def columns(self) -> tuple[str, ...]:
        """The columns of ``rows``, in order."""
        return GRIPPER_GRASP_COLUMNS if self.table == "gripper_grasps" else _GRASP_COLUMNS


def resolve_planner(spec: str | None = None) -> str:
    """The planner name to use: ``spec``, else ``$SYNTH_DB_PLANNER``, else the synth planner.

    Parameters
    ----------
    spec : str, optional
        ``"module:function"``.

    Returns
    -------
    str
        A ``"module:function"`` name (checked for form, not imported).

    Raises
    ------
    InputError
        If the name is not of the form ``module:function``.
    """
    if spec is not None and not isinstance(spec, str):
        raise InputError(f"planner: expected 'module:function' (text), got {spec!r}")
    name = spec or os.environ.get(PLANNER_ENV) or DEFAULT_PLANNER
    module, sep, func = name.partition(":")
    if not sep or not module or not func:
        where = "--planner, Python: planner=" if spec else PLANNER_ENV
        raise InputError(f"planner {name!r} (from {where}) must be 'module:function', e.g. "
                         "'synth.plan:plan_mesh_file'")
    return name


def load_planner(name: str) -> Callable[[str, dict[str, Any]], dict[str, Any]]:
    """Import and return the planner function named ``"module:function"``.

    Raises
    ------
    InputError
        If the module cannot be imported or has no such function.
    """
    module, _, func = name.partition(":")
    try:
        mod = importlib.import_module(module)
    except ImportError as e:
        raise InputError(f"cannot import planner module {module!r} (planner {name!r}): {e}") from e
    fn = getattr(mod, func, None)
    if not callable(fn):
        raise InputError(f"planner {name!r}: module {module!r} has no function {func!r}")
    return fn  # type: ignore[no-any-return]


def plan_one(path: str, params: dict[str, Any], planner: str | None = None) -> dict[str, Any]:
    """Plan grasps for one mesh file with the configured planner.

    Parameters
    ----------
    path : str
        Mesh file.
    params : dict
        Planner parameters (``contacts``, ``mu``, ``top``, ``seed``, ``finger_radius``, ``evals``).
    planner : str, optional
        ``"module:function"``; default from :func:`resolve_planner`.

    Returns
    -------
    dict
        The planner's JSON document (format ``synth.grasps`` version 1).

    Examples
    --------
    >>> doc = plan_one("box.stl", {"contacts": 7, "seed": 0, "evals": 2000})  # doctest: +SKIP
    """
    return load_planner(resolve_planner(planner))(path, dict(params))


#: Seconds between repeats of the per-mesh alarm once it has fired (see :class:`_TimeLimit`).
_REPEAT = 0.1


class _TimeLimit:
    """Raise :class:`_Timeout` in the block after ``seconds``, when run in a main thread (SIGALRM).

    ``expired`` tells afterwards whether the limit was reached, even if the planner caught the
    exception and raised another one (or returned). The alarm repeats every ``_REPEAT``
    seconds until the block ends: an exception raised where Python cannot pass it on (a
    garbage-collector callback, a ``__del__``) is lost, and the next one stops the planner.
    """

    def __init__(self, seconds: float | None) -> None:
        self.seconds = seconds
        self.expired = False
        self._previous: Any = None
        self._armed = (
            seconds is not None
            and hasattr(signal, "setitimer")
            and threading.current_thread() is threading.main_thread()
        )

    def _raise(self, signum: int, frame: object) -> None:
        self.expired = True
        raise _Timeout  # also from __exit__ before it disarms: run_one catches it there too

    def __enter__(self) -> _TimeLimit:
        if self._armed:
            self._previous = signal.signal(signal.SIGALRM, self._raise)
            signal.setitimer(signal.ITIMER_REAL, float(self.seconds),  # type: ignore[arg-type]
                             _REPEAT)
        return self

    def __exit__(self, *exc: object) -> None:
        if self._armed:
            signal.setitimer(signal.ITIMER_REAL, 0.0)
            signal.signal(signal.SIGALRM, self._previous)


def _pack_grasp(rank: int, g: dict[str, Any]) -> tuple[Any, ...]:
    points = g["points"]
    k = len(points)
    fingers = g["fingers"]
    f = len(fingers["tip_centers"])
    features = [str(s) for s in g["features"]]
    if len(features) != k:
        raise ValueError(f"features has {len(features)} entries, expected {k}")
    return (
        rank,
        float(g["d_star"]),
        str(g["closure"]),
        float(g["conditioning"]),
        float(g["epsilon"]),
        k,
        pack_array(points, (k, 3)),
        pack_array(g["normals"], (k, 3)),
        json.dumps(features),
        pack_array(g["regions"], (k,), dtype="<i8"),
        f,
        pack_array(fingers["tip_centers"], (f, 3)),
        float(fingers["tip_radius"]),
        pack_array(fingers["approach"], (f, 3)),
        float(fingers["body_length"]),
        float(fingers["body_radius"]),
        None if g.get("tolerance") is None else float(g["tolerance"]),
        None if g.get("contact_regions") is None else canonical_json(g["contact_regions"]),
        _sim_text(g),
        *(None if g.get(m) is None else float(g[m])
          for m in ("squeeze_per_weight", "least_squeeze", "margin")),
    )


def _pack_gripper_grasp(rank: int, g: dict[str, Any], gripper: str) -> tuple[Any, ...]:
    m = g["measures"]

    def opt(value: Any) -> float | None:
        return None if value is None else float(value)

    return (
        rank, gripper, pack_array(g["pose"], (4, 4)), pack_array(g["tcp"], (3,)),
        float(g["width"]), pack_array([c["point"] for c in g["contacts"]], (2, 3)),
        pack_array([c["normal"] for c in g["contacts"]], (2, 3)),
        float(m["squeeze_per_weight"]), opt(m["least_squeeze"]), opt(m["margin"]),
        opt(m["mu_min"]), float(m["epsilon"]), float(m["d_star"]), _sim_text(g),
    )  # fmt: skip


def _sim_text(g: dict[str, Any]) -> str | None:
    """The ``sim`` column of a grasp: canonical JSON of its simulation label, or None."""
    sim = g.get("sim")
    if sim is None:
        return None
    if not isinstance(sim, dict):
        raise ValueError(f"'sim' is a {type(sim).__name__}, not an object")
    return canonical_json(_json_ready(sim))


def _failure(
    path: str, kind: str, error: str, start: float, report: str | None = None
) -> PlanOutcome:
    return PlanOutcome(
        path, False, kind, error, None, None, None, None, (), None, time.perf_counter() - start,
        report,
    )  # fmt: skip


def crashed(path: str, reason: str) -> PlanOutcome:
    """The outcome of a task whose worker died (or whose Dask task failed) with ``reason``:
    ``error_kind`` ``"crashed"``."""
    return PlanOutcome(path, False, "crashed", reason, None, None, None, None, (), None, 0.0)


def _planner_failure(path: str, e: Exception, start: float) -> PlanOutcome:
    """The outcome of a planner that raised ``e``."""
    if isinstance(e, MeshError):
        return _failure(path, "mesh", f"cannot load mesh: {e}", start)
    if isinstance(e, SynthError):
        return _failure(path, "planner", f"{type(e).__name__}: {e}", start)
    return _failure(path, "planner", f"planner raised {type(e).__name__}: {e}", start)


def _json_ready(value: Any) -> Any:
    """``value`` with only JSON types: numpy values as Python ones, non-finite floats as None."""
    if isinstance(value, dict):
        return {str(k): _json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_ready(v) for v in value]
    if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):  # numpy arrays, scalars
        return _json_ready(value.tolist())
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if value is None or isinstance(value, (bool, int, str)):
        return value
    return str(value)


def mesh_report(mesh: Any) -> str | None:
    """The ``meshes.mesh_report`` text of a planner document's ``mesh`` object.

    Canonical JSON (sorted keys, no spaces) of ``mesh`` without ``path`` and ``sha256``, which
    the database keeps in columns of their own. Whatever else the planner put there is kept as
    it is, made JSON-safe (numpy values as numbers and lists, NaN and infinities as null).

    Parameters
    ----------
    mesh : dict or None
        The document's ``mesh`` object.

    Returns
    -------
    str or None
        None if ``mesh`` is None.

    Raises
    ------
    ValueError
        If ``mesh`` is neither None nor a JSON object (a dict).
    """
    if mesh is None:
        return None
    if not isinstance(mesh, dict):
        raise ValueError(f"'mesh' is a {type(mesh).__name__}, not an object")
    report = {k: v for k, v in mesh.items() if k not in ("path", "sha256")}
    return canonical_json(_json_ready(report))


def _simulated(path: str, doc: Any, settings: dict[str, Any], params: dict[str, Any]
               ) -> tuple[Any, str | None]:
    """The planner's document with every grasp simulated (:func:`synth.sim.simulate_plan`).
    A simulation synth could not run (its own failure, or the simulation's packages missing
    on this worker) never loses the plan: each grasp is stored with an error label saying
    why (:func:`synth.sim.unsimulated`). A document with nothing to simulate (not a plan, no
    grasp, cut by the time cap) is returned as it is, to be recorded for what it is. The
    second value is always None (kept for the caller's failure path)."""
    timing = doc.get("timing") if isinstance(doc, dict) else None
    if not isinstance(doc, dict) or doc.get("format") not in _FORMATS or not doc.get("grasps") \
            or (isinstance(timing, dict) and timing.get("stopped_by_time")):
        return doc, None
    from synth.plan import load_options
    from synth.sim.plans import unsimulated
    from synth.sim.settings import SimSettings

    st = SimSettings.from_dict(settings)
    try:
        from synth.sim import require_sim, simulate_plan

        require_sim()
        return simulate_plan(doc, path, st, load=load_options(params)), None
    except SynthError as e:
        return unsimulated(doc, f"simulation failed: {e}", st), None
    except Exception as e:  # noqa: BLE001 - a simulation bug must not stop a long run
        return unsimulated(doc, f"simulation raised {type(e).__name__}: {e}", st), None


def run_one(
    path: str, params: dict[str, Any], planner: str, timeout: float | None = None
) -> PlanOutcome:
    """Plan one mesh and pack the result; never raises for a bad mesh or a planner failure.

    Parameters
    ----------
    path : str
        Mesh file.
    params : dict
        Planner parameters, and ``sim``: None, or the :class:`synth.sim.SimSettings` fields
        with which every grasp found is simulated (``synth db build --sim``; the planner
        never sees this key). A simulation that fails records the mesh as failed with
        ``error_kind`` ``"sim"``.
    planner : str
        ``"module:function"`` (resolved by the parent).
    timeout : float, optional
        Seconds of planning and simulation (the planner's module is imported before the clock
        starts) before the task is stopped and recorded as failed with ``error_kind``
        ``"timeout"``, whatever it was doing then. Enforced with SIGALRM when the task runs in
        a process's main thread (the local engine); not enforced in Dask worker threads.

    Returns
    -------
    PlanOutcome
        Packed grasps, or the failure category and reason.
    """
    start = time.perf_counter()
    limit = _TimeLimit(timeout)
    doc: Any = None
    sim_error: str | None = None
    given = {k: v for k, v in params.items() if k != "sim"}
    try:
        plan = load_planner(resolve_planner(planner))
        with limit:
            doc = plan(path, given)
            if params.get("sim") is not None:
                doc, sim_error = _simulated(path, doc, params["sim"], given)
    except _Timeout:
        pass
    except Exception as e:  # noqa: BLE001 - a planner bug must not stop a long run
        if not limit.expired:
            return _planner_failure(path, e, start)
    if limit.expired:
        return _failure(path, "timeout", f"timed out: the mesh exceeded --timeout {timeout:g} s",
                        start)  # fmt: skip
    try:
        if not isinstance(doc, dict) or doc.get("format") not in _FORMATS:
            raise ValueError("not a 'synth.grasps' or 'synth.gripper_grasps' document")
        if doc.get("version") != 1:
            raise ValueError(f"format version {doc.get('version')!r}, expected 1")
        grasps = doc["grasps"]
        table = _FORMATS[doc["format"]]
        if table == "gripper_grasps":
            name = str(doc["gripper"]["name"])
            rows = tuple(_pack_gripper_grasp(i + 1, g, name) for i, g in enumerate(grasps))
        else:
            rows = tuple(_pack_grasp(i + 1, g) for i, g in enumerate(grasps))
        mesh = doc.get("mesh")
        report = mesh_report(mesh)
        mesh = mesh or {}
        timing = doc.get("timing", {})
        units = mesh.get("units")
        length = mesh.get("length")
        plan_s = timing.get("total_s")
        outcome_meta = (
            None if units is None else str(units),
            None if length is None else float(length),
            json.dumps(doc.get("params", {}), sort_keys=True, default=str),
            None if doc.get("synth_version") is None else str(doc["synth_version"]),
            None if plan_s is None else float(plan_s),
        )
    except (KeyError, TypeError, ValueError) as e:
        return _failure(path, "invalid_result", f"planner returned an invalid document: {e}", start)
    if sim_error is not None:
        return _failure(path, "sim", sim_error, start, report)
    if timing.get("stopped_by_time"):
        return _failure(
            path, "time_cap",
            "the planner's time cap ('time' in the database's parameters) cut the search, so "
            "its result would depend on the machine's speed; plan this mesh alone with "
            "'synth plan', or build another database with a smaller --evals", start,
            report,
        )
    if not rows:
        message = doc.get("message")
        reason = "no grasp found" + (f": {message}" if message else "")
        return PlanOutcome(
            path, False, "no_grasp", reason, outcome_meta[0], outcome_meta[1], outcome_meta[2],
            outcome_meta[3], (), outcome_meta[4], time.perf_counter() - start, report, table,
        )  # fmt: skip
    return PlanOutcome(
        path, True, None, None, outcome_meta[0], outcome_meta[1], outcome_meta[2],
        outcome_meta[3], rows, outcome_meta[4], time.perf_counter() - start, report, table,
    )  # fmt: skip
