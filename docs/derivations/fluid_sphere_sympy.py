"""Reproduce the traction matrices K_in, K_out of docs/derivations/fluid_sphere.md with sympy.

For each degree l the axisymmetric Stokes modes u_r = L f / r^2 P_l, u_theta = f' / r dP_l/dtheta
(f = r^(l+1), r^(l+3) inside; r^(-l), r^(2-l) outside) get their pressure from grad p = mu lap u;
the script checks the momentum and mass balances, evaluates the traction on r = R = 1 and prints
K = (traction) (surface velocity)^-1 next to the closed forms. Run: python docs/derivations/fluid_sphere_sympy.py
"""

import sympy as sp

r, th = sp.symbols("r theta", positive=True)


def lap(g):
    return sp.diff(r**2 * sp.diff(g, r), r) / r**2 + sp.diff(sp.sin(th) * sp.diff(g, th), th) / (r**2 * sp.sin(th))


def mode(l, k):
    P = sp.legendre(l, sp.cos(th))
    L = l * (l + 1)
    f = r**k
    ur, ut = L * f / r**2 * P, sp.diff(f, r) / r * sp.diff(P, th)
    lr = lap(ur) - 2 * ur / r**2 - 2 / (r**2 * sp.sin(th)) * sp.diff(ut * sp.sin(th), th)
    lt = lap(ut) + 2 / r**2 * sp.diff(ur, th) - ut / (r**2 * sp.sin(th) ** 2)
    p = sp.integrate(sp.expand(sp.simplify(lr)), r)  # mu = 1
    div = sp.diff(r**2 * ur, r) / r**2 + sp.diff(sp.sin(th) * ut, th) / (r * sp.sin(th))
    for pt in ({r: sp.Rational(13, 10), th: sp.Rational(3, 10)}, {r: sp.Rational(7, 10), th: sp.Rational(11, 10)}):
        for residual in (sp.diff(p, th) / r - lt, div):  # momentum (theta; r holds by construction), mass
            assert abs(sp.N(residual.subs(pt), 50)) < 1e-35
    srr = -p + 2 * sp.diff(ur, r)
    srt = r * sp.diff(ut / r, r) + sp.diff(ur, th) / r
    at = {r: 1, th: sp.Rational(7, 10)}
    dP = sp.diff(P, th)
    pairs = ((ur, P), (ut, dP), (srr, P), (srt, dP))
    return [sp.nsimplify(sp.N((e / d).subs(at), 30), rational=True) for e, d in pairs]


def K(l, powers):
    cols = [mode(l, k) for k in powers]
    V = sp.Matrix([[c[0] for c in cols], [c[1] for c in cols]])
    S = sp.Matrix([[c[2] for c in cols], [c[3] for c in cols]])
    return S * V.inv()


if __name__ == "__main__":
    for l in range(1, 7):
        k_in, k_out = K(l, [l + 1, l + 3]), K(l, [-l, 2 - l])
        want_in = sp.Matrix([[sp.Rational(2 * l * l + l + 3, l), -3 * (l + 1)], [sp.Rational(-3, l), 2 * l + 1]])
        want_out = sp.Matrix(
            [[-sp.Rational(2 * l * l + 3 * l + 4, l + 1), 3 * l], [sp.Rational(3, l + 1), -(2 * l + 1)]]
        )
        print(f"l = {l}: K_in {k_in.tolist()} K_out {k_out.tolist()}", k_in == want_in and k_out == want_out)
