"""Benchmark: how far the simulated part stands out of the planned surface where fingers touch.

For every plannable corpus part (``--files`` to choose), the planner's top ``--top`` point-finger
grasps at the defaults (seed 0) are put into ``synth sim``'s scene, each finger placed exactly at
its planned touch (no dynamics: the slide joints set to the touch targets), and MuJoCo's
contacts are listed. A fingertip at its planned touch rests on the planned surface: any contact
deeper than round-off is with collision geometry that stands out of that surface (a slab of the
part's facets, ``synth.sim.shape``), which would push the finger where the plan says nothing
does. Printed per part: the deepest such contact of each grasp, in tip radii; then, over all
grasps, how many meet such geometry and the largest depth.

This measures the simulated shape, not the planner: the planner checks every fingertip against
the mesh itself. Usage:

    python scripts/bench_touch.py [--files a.obj b.stl] [--top 5]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CORPUS = ROOT / "meshes" / "corpus"

from synth.part import load_part  # noqa: E402
from synth.plan import PlanParams, plan_part  # noqa: E402
from synth.sim.contact import ContactModel  # noqa: E402
from synth.sim.document import check_document  # noqa: E402
from synth.sim.scene import build_scene  # noqa: E402
from synth.sim.settings import SimSettings  # noqa: E402
from synth.sim.shape import part_shape  # noqa: E402
from synth.sim.simulate import balanced_preload  # noqa: E402

#: Depths below this share of a tip radius are round-off of a resting contact.
ROUND_OFF = 1e-4


def touch_depths(path: Path, units: str | None, top: int) -> list[float]:
    """The deepest contact of each of the plan's top grasps at the planned touch, in tip
    radii (0 when none is deeper than ``ROUND_OFF``)."""
    import mujoco

    part = load_part(path, units=units)
    doc = plan_part(part, PlanParams(top=top)).to_json()
    if not doc["grasps"]:
        return []
    f = check_document(doc, str(path))
    st, model, shape = SimSettings(), ContactModel(f.mu), part_shape(part)
    out = []
    for g in f.grasps:
        pre = balanced_preload(g, f.center_mass, f.length, model.mu, st.grip)
        sc = build_scene(shape, g.tip_centers, g.approach, g.tip_radius, length=f.length,
                         center_mass=f.center_mass, volume=f.volume, settings=st,
                         contact=model, preload=pre)
        m = sc.model
        d = mujoco.MjData(m)
        for j, q in enumerate(sc.ctrl_touch):
            d.qpos[m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT,
                                                   f"slide{j}")]] = q
        mujoco.mj_forward(m, d)
        deep = -min([float(c.dist) for c in d.contact[: d.ncon]] + [0.0]) / sc.scale
        depth = deep / g.tip_radius
        out.append(depth if depth > ROUND_OFF else 0.0)
    return out


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print its figures."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--files", nargs="*", default=None)
    ap.add_argument("--top", type=int, default=5)
    args = ap.parse_args(argv)
    entries = {e["file"]: e for e in json.loads((CORPUS / "corpus.json").read_text())
               if e.get("expect", "plan") == "plan"}
    names = args.files or sorted(entries)
    every: list[float] = []
    for name in names:
        path = CORPUS / name if (CORPUS / name).exists() else Path(name)
        depths = touch_depths(path, entries.get(path.name, {}).get("units"), args.top)
        every += depths
        shown = " ".join(f"{x:.3f}" for x in depths) or "no grasp"
        print(f"{path.name:50s} {shown}", flush=True)
    met = [x for x in every if x > 0]
    print(f"\n{len(every)} grasps: {len(met)} meet geometry standing out of the planned surface "
          f"at their touch; deepest {max(every, default=0.0):.3f} tip radii")
    return 0


if __name__ == "__main__":
    sys.exit(main())
