"""Question: Is the one growing mode the 3D code finds on the furrow_p4_a1 shapes (t = 1, 3) a defect of
the 3D discretisation?

Answer: No: the axisymmetric solver linearised on the full meridian with the same zero-mean-velocity
constraint has the same eigenvalue (+0.3207 / +0.3612 at t = 1 / 3; a perturbed nonlinear run grows at
0.367) and nothing else above 0.031; with the centroid held no mode grows (largest +0.046 / +0.0011). It
is the model's free rigid translation. docs/validation/formulations.md (25 s).

Independent check, with the axisymmetric spectral solver on the FULL meridian (no up-down
symmetry reduction), of the growing odd mode the 3D code finds on furrow_p4_a1 at t = 1, 3.

    python benchmarks/investigations/axisym_translation_mode.py            # everything (~30 s, one core)
    python benchmarks/investigations/axisym_translation_mode.py --quick    # n = 96 only (~15 s)
    python benchmarks/investigations/axisym_translation_mode.py --n=64,128 # the resolution check only
    python benchmarks/investigations/axisym_translation_mode.py --smoke    # smoke test: n = 32, seconds

For bending viscosity on (scene values) and off (eta_bar = eta_bar_b = 0):
  1. simulate(..., symmetric=False, parametrization='lagrangian') to t = 1, 3 (full meridian,
     gauge 'velocity' = oint v_z dA = 0, the 3D code's convention; n = 2 x the scene's 48),
  2. J = Dynamics.jac(t, y) (exact complex-step Jacobian of the (r, z) node dynamics), eigenvalues:
     - full J, and its mirror-even / mirror-odd blocks (z -> -z),
     - the normal-normal operator J_nn = N^T J N (the 3D code's J s = d v_n/dX [s n]),
     each eigenvector's normal fraction and parity of its normal component s,
     and the decomposition of the odd mode's s into the normal part of a rigid z-translation
     (c n_z: translation + a slide of the labels/tension pattern along the surface) + the rest,
  3. the same Jacobian with the other translation gauge of the solver ('centroid': oint z v_n dA = 0)
     and with material points advected by the full velocity (v_n n + v_s t; exploratory),
  4. nonlinear: from the t = 1 state + eps * odd eigenvector, integrate to t = 3 in both gauges and
     measure growth rates of a purely geometric asymmetry (z_N + z_S - 2 z_vol-centroid) and of the
     ring's offset from the volume centroid (z(label pi/2) - z_centroid).
"""

from __future__ import annotations

import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from scipy.integrate import Radau

from cortex_ti.axisymmetric.dynamics import Dynamics, full_meridian_dynamics, normal_embedding
from cortex_ti.axisymmetric.evolve import _integrate, simulate
from cortex_ti.axisymmetric.run import axisymmetric_tension, viscosities
from cortex_ti.axisymmetric.spectral import Spectral
from cortex_ti.scene.loader import load_scene

QUICK = "--quick" in sys.argv
SMOKE = "--smoke" in sys.argv  # smoke test: n = 32, a loose tolerance, every section once; numbers mean nothing
SETTINGS = load_scene("furrow_p4_a1", ["model=axisymmetric"]).settings
ZETA = axisymmetric_tension(SETTINGS)
RTOL = 1e-6 if SMOKE else 1e-10


def visc(bending: bool) -> dict:
    v = viscosities(SETTINGS)
    if not bending:
        v.update(eta_bar=0.0, eta_bar_b=0.0)
    return v


class FullAdvection(Dynamics):
    """Exploratory variant: material points (and the tension on them) move with v_n n + v_s t."""

    def velocity(self, g, x):
        n = self.n
        vs, vn = x[..., :n], x[..., n : 2 * n]
        dr = -vn * g["zs"] + vs * g["rs"]
        dz = vn * g["rs"] + vs * g["zs"]
        return np.concatenate([dr @ self.sp.FR.T, dz], axis=-1)


def dynamics(n: int, v: dict, gauge: str = "velocity", cls=Dynamics) -> Dynamics:
    """The full-meridian lagrangian dynamics exactly as simulate builds it."""
    return full_meridian_dynamics(ZETA, n, **v, gauge=gauge, cls=cls)


def states(n: int, v: dict, times):
    res = simulate(
        ZETA,
        **v,
        t_end=max(times),
        save_times=[0.0, *times],
        n=n,
        rtol=RTOL,
        symmetric=False,
        parametrization="lagrangian",
        gauge="velocity",
    )
    assert res.params["symmetric"] is False and res.params["parametrization"] == "lagrangian"
    return {t: np.concatenate([res.r[res.index(t)], res.z[res.index(t)]]) for t in times}, res


def mirror(n: int) -> np.ndarray:
    """M (r, z)(u) = (r(pi - u), -z(pi - u)): the z -> -z reflection of a node perturbation."""
    P = np.eye(n)[::-1]
    return np.block([[P, np.zeros((n, n))], [np.zeros((n, n)), -P]])


def parity_basis(n: int, sgn: int) -> np.ndarray:
    """Orthonormal basis of {d : M d = sgn d} (n even: no node on the equator)."""
    Q = np.zeros((2 * n, n))
    for j in range(n // 2):
        Q[j, j], Q[n - 1 - j, j] = 1.0, sgn
        Q[n + j, n // 2 + j] = 1.0
        Q[2 * n - 1 - j, n // 2 + j] = -sgn
    Q /= np.sqrt(2.0)
    assert np.allclose(mirror(n) @ Q, sgn * Q)
    return Q


def frames(dyn: Dynamics, y: np.ndarray):
    """Per-node outward normal N and tangent T (north -> south) as (2n x n) embeddings, and g."""
    g = dyn.geometry(y)
    n = dyn.n
    i = np.arange(n)
    T = np.zeros((2 * n, n))
    T[i, i], T[n + i, i] = g["rs"], g["zs"]
    return normal_embedding(dyn, y), T, g


def block_eig(J: np.ndarray, n: int, sgn: int):
    Q = parity_basis(n, sgn)
    w, V = np.linalg.eig(Q.T @ J @ Q)
    return w, Q @ V


def describe(dyn, y, w, V, k) -> str:
    N, T, g = frames(dyn, y)
    v = V[:, k]
    v = np.real(v * np.exp(-1j * np.angle(v[np.argmax(np.abs(v))])))
    s, a = N.T @ v, T.T @ v
    fn = s @ s / (s @ s + a @ a)
    par = np.linalg.norm(s + s[::-1]) / max(np.linalg.norm(s - s[::-1]), 1e-300)
    wA = dyn.sp.wR * g["r"] * g["h"]
    nz = g["rs"]
    c = (wA * s * nz).sum() / (wA * nz * nz).sum()
    rest = np.sqrt((wA * (s - c * nz) ** 2).sum() / (wA * s * s).sum())
    return (
        f"{w[k].real:+8.4f}{w[k].imag:+.0e}i  normal frac {fn:5.3f}  |s_even|/|s_odd| {par:7.1e}  "
        f"s - (translation part c n_z): {rest:5.3f} of |s|"
    )


def analyse(dyn: Dynamics, y: np.ndarray, t: float, verbose: bool = True) -> dict:
    n = dyn.n
    J = dyn.jac(t, y)
    M = mirror(n)
    w = np.linalg.eigvals(J)
    wo, Vo = block_eig(J, n, -1)
    we, Ve = block_eig(J, n, +1)
    N, _, _ = frames(dyn, y)
    wn, Vn = np.linalg.eig(N.T @ J @ N)
    if verbose:
        print(
            f"  t = {t:g}: |My - y|/|y| = {np.linalg.norm(M @ y - y) / np.linalg.norm(y):.0e}, "
            f"|MJ - JM|/|J| = {np.linalg.norm(M @ J - J @ M) / np.linalg.norm(J):.0e}"
        )
        print("    full J rightmost Re:", " ".join(f"{x:+.4f}" for x in np.sort(w.real)[::-1][:5]))
        for name, (ww, VV) in (("odd ", (wo, Vo)), ("even", (we, Ve))):
            for j, k in enumerate(np.argsort(-ww.real)[:2]):
                print(f"    {name if j == 0 else '    '} {describe(dyn, y, ww, VV, k)}")
        ks = np.argsort(-wn.real)[:3]
        pars = []
        for k in ks:
            s = np.real(Vn[:, k] * np.exp(-1j * np.angle(Vn[np.argmax(np.abs(Vn[:, k])), k])))
            pars.append(
                "odd"
                if np.linalg.norm(s + s[::-1]) < 1e-6 * np.linalg.norm(s)
                else "even"
                if np.linalg.norm(s - s[::-1]) < 1e-6 * np.linalg.norm(s)
                else "mixed"
            )
        print(
            "    J_nn = N^T J N (3D code's operator):",
            "  ".join(f"{wn[k].real:+.4f} ({p})" for k, p in zip(ks, pars, strict=False)),
        )
    k = int(np.argmax(wo.real))
    vec = np.real(Vo[:, k] * np.exp(-1j * np.angle(Vo[np.argmax(np.abs(Vo[:, k])), k])))
    return dict(
        odd=float(wo.real.max()), even=float(we.real.max()), nn=float(wn.real.max()), vec=vec / np.abs(vec).max()
    )


def measures(sp: Spectral, y: np.ndarray, m: int = 4001):
    """(geometric asymmetry z_N + z_S - 2 z_c, ring offset z(pi/2) - z_c), z_c = volume centroid."""
    n = sp.n
    uu = np.linspace(0.0, np.pi, m)
    r = sp.evaluate("R", y[:n] @ sp.FR.T, uu)
    z = sp.evaluate("Z", y[n:], uu)
    zu = sp.evaluate("Z", y[n:], uu, 1)

    def trap(f):
        return float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(uu)))

    vol = trap(np.pi * r**2 * (-zu))
    zc = trap(np.pi * r**2 * z * (-zu)) / vol
    return z[0] + z[-1] - 2 * zc, z[m // 2] - zc


def nonlinear(v: dict, y1: np.ndarray, vec: np.ndarray, eps: float, n: int = 96) -> None:
    times = np.linspace(1.0, 3.0, 9)
    print(f"  nonlinear from t = 1: y1 + {eps:g} x (velocity-gauge odd eigenvector, max-norm 1), Radau rtol 1e-12")
    print("    gauge     t    asym=zN+zS-2zc  rate    ring offset   rate    [odd eig of J(t), this gauge]")
    for gauge in ("velocity", "centroid"):
        dyn = dynamics(n, v, gauge)
        saved, _, _, _ = _integrate(dyn, y1 + eps * vec, times - 1.0, 2.0, Radau, 1e-12, 1e-13, True, 100000)
        base, _, _, _ = _integrate(dyn, y1.copy(), times - 1.0, 2.0, Radau, 1e-12, 1e-13, True, 100000)
        prev = None
        for i, t in enumerate(times):
            a, o = measures(dyn.sp, saved[i][1])
            a0, o0 = measures(dyn.sp, base[i][1])
            a, o = a - a0, o - o0
            eig = analyse(dyn, base[i][1], t, verbose=False)["odd"]
            if i % 2 == 0:
                ra = "   -   " if prev is None else f"{np.log(abs(a / prev[0])) / (t - prev[2]):+.4f}"
                ro = "   -   " if prev is None else f"{np.log(abs(o / prev[1])) / (t - prev[2]):+.4f}"
                print(f"    {gauge:8s} {t:4.2f}  {a:+.4e}  {ra}  {o:+.4e}  {ro}   [{eig:+.4f}]")
                prev = (a, o, t)


def main():
    t_start = time.time()
    ns = (32,) if SMOKE else (96,) if QUICK else (64, 96, 128)
    analysed = ns[0] if SMOKE else 96  # the resolution the gauge and nonlinear sections run at
    for a in sys.argv[1:]:
        if a.startswith("--n="):
            ns = tuple(int(x) for x in a[4:].split(","))
    for bending in (True, False):
        v = visc(bending)
        tag = f"bending {'on' if bending else 'off'} (eta_bar={v['eta_bar']:g}, eta_bar_b={v['eta_bar_b']:g})"
        for n in ns:
            ys, res = states(n, v, (1.0, 3.0))
            dyn = dynamics(n, v)
            print(
                f"\n##### {tag}, n = {n} full-meridian nodes, gauge 'velocity' (oint v_z dA = 0); "
                f"pole radius {res.pole_radius[1]:.5f}, {res.pole_radius[2]:.5f}; furrow radius "
                f"{res.furrow_radius[1]:.5f}, {res.furrow_radius[2]:.5f}; min k1 "
                f"{dyn.geometry(ys[3.0])['k1'].min():+.3f}"
            )
            info = {t: analyse(dyn, ys[t], t) for t in (1.0, 3.0)}
            if n != analysed:
                continue
            for gauge, cls, name in (
                ("centroid", Dynamics, "gauge 'centroid' (oint z v_n dA = 0)"),
                ("velocity", FullAdvection, "full advection v_n n + v_s t, gauge 'velocity'"),
                ("centroid", FullAdvection, "full advection v_n n + v_s t, gauge 'centroid'"),
            ):
                d2 = dynamics(n, v, gauge, cls)
                print(f"  same states, {name}:")
                for t in (1.0, 3.0):
                    J = d2.jac(t, ys[t])
                    wo, Vo = block_eig(J, n, -1)
                    we, Ve = block_eig(J, n, +1)
                    print(f"    t = {t:g}: odd  {describe(d2, ys[t], wo, Vo, int(np.argmax(wo.real)))}")
                    print(f"           even {describe(d2, ys[t], we, Ve, int(np.argmax(we.real)))}")
            nonlinear(v, ys[1.0], info[1.0]["vec"], 1e-6, n)
    print(f"\n(total {time.time() - t_start:.1f} s)")


if __name__ == "__main__":
    main()
