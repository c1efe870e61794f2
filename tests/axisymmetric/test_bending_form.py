"""The axisymmetric model's two forms of the bending viscosity (``bending_form``): paper Eq. 45,
``beta^cd nabla_c nabla_d v_n + beta_0 v_n``, and the force of the dissipation the 3D Rayleighian
formulations integrate, ``nabla_c (beta^cd nabla_d v_n) + beta_0 v_n``.

Independent truths: the two coincide on a sphere (uniform curvature, ``nabla_c beta^cd = 0``); the
dissipation's force is self-adjoint in ``L2(dA)`` (it is the derivative of a quadratic form), Eq. 45
is not on a shape whose curvature varies. Measured on an ellipsoid of revolution (a = 1.2, c = 0.8,
n = 48, smooth speeds): relative asymmetry 1.5e-14 (dissipation) against 0.91 (paper).
"""

import numpy as np
import pytest

from cortex_ti.axisymmetric.balance import ForceBalance, check_visc
from cortex_ti.axisymmetric.spectral import Spectral, geometry


def _bending_operator(form: str, a: float, c: float, n: int = 48):
    """The bending normal force at the nodes for unit normal speeds at each node (n, n) and the area
    weights of the nodes, on the ellipsoid r = a sin u, z = c cos u."""
    sp = Spectral(n, symmetric=False)
    g = geometry(sp, a * np.sin(sp.u), c * np.cos(sp.u))
    g["zeta"] = np.zeros(n)
    with_b = ForceBalance(sp, check_visc(1.0, 1.0, 5e-4, 2.5e-3, 1.0, bending_form=form))
    without = ForceBalance(sp, check_visc(1.0, 1.0, 0.0, 0.0, 1.0))
    unit = np.eye(n)
    op = with_b.balance(np.zeros((n, n)), unit, g)[1] - without.balance(np.zeros((n, n)), unit, g)[1]
    return op.T, sp.wR * g["r"] * g["h"]  # [i, j]: force at node i of v_n = e_j


@pytest.mark.parametrize("form", ["paper", "dissipation"])
def test_both_forms_agree_on_a_sphere(form):
    op, _ = _bending_operator(form, 1.0, 1.0)
    ref, _ = _bending_operator("paper", 1.0, 1.0)
    assert np.abs(op - ref).max() <= 1e-12 * np.abs(ref).max()


def test_the_dissipation_form_is_self_adjoint_and_eq45_is_not():
    """``int w F(v) dA - int v F(w) dA`` for smooth normal speeds (cos u, cos 2u + 0.3 cos 3u, ...),
    relative to ``int |w F(v)| dA``: zero to the spectral accuracy for the dissipation form."""
    asym = {}
    for form in ("paper", "dissipation"):
        op, wt = _bending_operator(form, 1.2, 0.8)
        u = Spectral(48, symmetric=False).u
        fields = [np.cos(u), np.cos(2 * u) + 0.3 * np.cos(3 * u), np.cos(u) ** 3, np.exp(np.cos(u))]
        worst = 0.0
        for i, v in enumerate(fields):
            for w in fields[i + 1 :]:
                a, b = wt @ (w * (op @ v)), wt @ (v * (op @ w))
                worst = max(worst, abs(a - b) / (wt @ np.abs(w * (op @ v))))
        asym[form] = worst
    assert asym["dissipation"] < 1e-8, asym
    assert asym["paper"] > 1e-3, asym


def test_an_unknown_bending_form_is_refused():
    with pytest.raises(ValueError, match="bending_form"):
        check_visc(1.0, 1.0, 5e-4, 2.5e-3, 1.0, bending_form="strong")
