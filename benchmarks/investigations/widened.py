"""Question: Do widened fit stencils and user meshes keep the convergence order?

Answer: For rayleigh_p1, yes on smooth user meshes (graded mesh: 1.3e-2 / 3.4e-3 / 9.4e-4 at 642 / 2562
/ 10242, ratios 3.8, 3.6), and the two-ring stencils change nothing for it; the paper formulation loses
order there (graded: ratios 3.1, 1.8). On a mesh jittered at every level both lose order (ratios 2.9,
2.2 for rayleigh_p1), rayleigh_p1 staying 3-4.5x more accurate. docs/validation/formulations.md.

Do widened fit stencils and user meshes keep the convergence order? Static Y20 full on
icospheres whose valence-5 nodes get the two-ring stencil (what StencilChooser does at degenerate
nodes), and on meshes read through ``mesh.file``: a smoothly graded one (every icosphere node
moved along the sphere by a smooth tangential field, so the node spacing varies by a factor ~2
over the sphere, the same map at every resolution) and an irregular one (nodes moved
tangentially at random by up to ``--jitter`` of the local edge length and put back on the
sphere; a fixed seed; irregular at every scale, so no method keeps its order there).

Usage::

    python benchmarks/investigations/widened.py --nodes 642 2562 10242 --formulations paper rayleigh_p1
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: its _bench
import _bench  # noqa: E402  (benchmarks/_bench.py: the helpers every benchmark shares)
import numpy as np


def jittered_mesh(nodes: int, amount: float, path: str) -> None:
    import meshio

    from cortex_ti.surface.mesh import icosphere
    from cortex_ti.surface.topology import build_topology

    m = icosphere(nodes)
    topo = build_topology(m)
    x = m.points.copy()
    ring = topo.ring
    d = np.linalg.norm(x[np.maximum(ring, 0)] - x[:, None, :], axis=2)
    h = np.where(ring >= 0, d, np.inf).min(axis=1)
    rng = np.random.default_rng(12345)
    step = rng.standard_normal(x.shape)
    step -= np.einsum("nc,nc->n", step, x)[:, None] * x
    step /= np.linalg.norm(step, axis=1)[:, None]
    x = x + (amount * h * rng.random(len(x)))[:, None] * step
    x /= np.linalg.norm(x, axis=1)[:, None]
    meshio.write(path, meshio.Mesh(x, [("triangle", m.faces)]))


def graded_mesh(nodes: int, path: str, strength: float = 0.35) -> None:
    """The icosphere mapped by x -> normalise(x + strength * z * (e_z x x) + strength * (x_z^2 - 1/3) e_z):
    smooth, so the mesh family is as regular as the icosphere's, but not uniform."""
    import meshio

    from cortex_ti.surface.mesh import icosphere

    m = icosphere(nodes)
    x = m.points
    swirl = np.cross(np.array([0.0, 0.0, 1.0]), x) * x[:, 2:3]
    lift = (x[:, 2:3] ** 2 - 1.0 / 3.0) * np.array([0.0, 0.0, 1.0])
    y = x + strength * (swirl + lift)
    y /= np.linalg.norm(y, axis=1)[:, None]
    meshio.write(path, meshio.Mesh(y, [("triangle", m.faces)]))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--nodes", type=int, nargs="+", default=[642, 2562, 10242])
    p.add_argument("--fit", default="quadratic")
    p.add_argument("--jitter", type=float, default=0.3)
    p.add_argument("--formulations", nargs="+", default=["paper", "rayleigh_p1"])
    p.add_argument("--set", dest="overrides", action="append", default=[])
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    if args.smoke:
        args.nodes = [162]
    from cortex_ti import runtime
    from cortex_ti.scene import load_scene
    from cortex_ti.simulation import Simulation
    from cortex_ti.truth import analytic

    runtime.init(threads=1)
    print("| mesh | N | fit | formulation | Y20 full eps_rel | ratio |")
    print("|---|---|---|---|---|---|")
    kinds = ("icosphere", "valence-5 widened", "graded file", "jittered file")
    for kind, form in ((k, f) for f in args.formulations for k in kinds):
        prev = None
        for n in args.nodes:
            ov = [
                f"mesh.nodes={n}",
                f"numerics.fit={args.fit}",
                f"numerics.formulation={form}",
                "solver.reuse=false",
            ] + args.overrides
            tmp = None
            if kind.endswith("file"):
                tmp = tempfile.NamedTemporaryFile(suffix=".ply", delete=False).name
                if kind == "jittered file":
                    jittered_mesh(n, args.jitter, tmp)
                else:
                    graded_mesh(n, tmp)
                ov.append(f"mesh.file={tmp}")
            scene = load_scene("sphere_y20_full", ov)
            sim = Simulation(scene)
            if kind == "valence-5 widened":
                sim.stencils.widen(np.flatnonzero(sim.topology.valence == 5))
            sol = sim.solve()
            x = sim.mesh.points
            exact, _ = analytic.sphere_full_solution(
                x, list(scene.settings.patterns), eta_b=scene.settings.viscosity.bulk
            )
            err = analytic.error_measures(sol.velocity, exact)[1]
            ratio = "" if prev is None else f"{prev / err:.2f}"
            prev = err
            print(f"| {kind} | {n} | {args.fit} | {scene['numerics.formulation']} | {err:.3e} | {ratio} |", flush=True)
            if tmp:
                os.unlink(tmp)
    return 0


if __name__ == "__main__":
    sys.exit(main())
