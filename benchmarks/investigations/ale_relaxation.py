"""Question: How fast does the ALE mesh flow mend a distortion, and what is the largest explicit step it
takes?

Answer: Slowly: a smooth distortion takes 50-190 ``ale_time`` to mend (3.9 / 4.0 / 9.5 t_a for l = 2 and
7.5 / 2.7 / 3.7 t_a for l = 4 at 162 / 642 / 2562 nodes with ``ale_time`` 0.05); the largest stable
explicit step is 0.9 ``ale_time`` on the sphere. Hence ``mesh.relax_start`` mends a sheared start before
t = 0 instead. docs/validation/material_cortex.md and docs/derivations/transport.md.

How fast the ALE mesh flow mends a distortion, and the largest step it takes explicitly.

The ALE tangential velocity (:func:`cortex_ti.dynamics.motion.ale_velocity`) is a local gradient
flow of the triangles' conformal distortion with mobility ``h^2 / (tau n_i)``. On the unit
icosphere (the reference: the mesh itself), with the shape held (no cortex flow, the nodes put back
on the sphere after each step):

* relaxation: the nodes displaced tangentially by ``eps grad Y_l0`` (a smooth distortion of
  degree l); the flow alone, explicit Euler at dt = tau / 5; the time in which the distortion's
  amplitude falls by e (fitted on the second half of 12 tau), in t_a and in units of tau;
* explicit limit: from a random small tangential distortion, Euler steps of dt = c tau for rising
  c; the largest c whose distortion does not grow over 40 steps.

Usage::

    python benchmarks/investigations/ale_relaxation.py --nodes 162 642 2562 --degrees 2 4

Cost: seconds (numpy only, no solve).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: its _bench
import _bench  # noqa: E402  (benchmarks/_bench.py: the helpers every benchmark shares)
import numpy as np

from cortex_ti.dynamics.motion import MotionContext, ale_velocity, conformal_distortion
from cortex_ti.surface.mesh import icosphere
from cortex_ti.truth.sphere_exact import real_sph_harm


def _flow(x, ctx, dt, steps):
    energy = []
    for _ in range(steps):
        energy.append(conformal_distortion(x, ctx).sum())
        x = x + dt * ale_velocity(np.zeros_like(x), x, x, ctx)
        x = x / np.linalg.norm(x, axis=1)[:, None]
    return np.array(energy)


def relaxation_time(nodes: int, l: int, tau: float, eps: float = 0.05) -> float:
    m = icosphere(nodes)
    x0 = m.points
    ctx = MotionContext(m.faces, x0, ale_time=tau)
    h = 1e-6
    grad = np.stack(
        [(real_sph_harm(l, 0, x0 + h * e) - real_sph_harm(l, 0, x0 - h * e)) / (2 * h) for e in np.eye(3)], 1
    )
    grad -= np.einsum("nc,nc->n", grad, x0)[:, None] * x0
    x = x0 + eps * grad / np.abs(grad).max()
    x /= np.linalg.norm(x, axis=1)[:, None]
    steps = 60
    dt = tau / 5.0
    energy = _flow(x, ctx, dt, steps)
    t = dt * np.arange(steps)
    rate = -np.polyfit(t[steps // 2 :], np.log(energy[steps // 2 :]), 1)[0] / 2.0  # energy ~ amplitude^2
    return 1.0 / rate


def explicit_limit(nodes: int, tau: float) -> float:
    m = icosphere(nodes)
    ctx = MotionContext(m.faces, m.points, ale_time=tau)
    rng = np.random.default_rng(0)
    d = 1e-4 * rng.standard_normal(m.points.shape)
    d -= np.einsum("nc,nc->n", d, m.points)[:, None] * m.points
    x = (m.points + d) / np.linalg.norm(m.points + d, axis=1)[:, None]
    stable = 0.0
    for c in np.arange(0.1, 2.01, 0.1):
        energy = _flow(x, ctx, c * tau, 40)
        if energy[-1] > energy[0]:
            break
        stable = c
    return stable


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--nodes", type=int, nargs="*", default=[162, 642, 2562])
    p.add_argument("--degrees", type=int, nargs="*", default=[2, 4])
    p.add_argument("--tau", type=float, default=0.05, help="mesh.ale_time")
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    if args.smoke:
        args.nodes, args.degrees = [162], [2]
    print(f"| N | l | relaxation time (t_a), tau = {args.tau:g} | in units of tau | largest stable dt / tau |")
    print("|---|---|---|---|---|")
    for nodes in args.nodes:
        limit = explicit_limit(nodes, args.tau)
        for l in args.degrees:
            t = relaxation_time(nodes, l, args.tau)
            print(f"| {nodes} | {l} | {t:.2f} | {t / args.tau:.0f} | {limit:.1f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
