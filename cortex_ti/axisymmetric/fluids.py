r"""The axisymmetric cortex between a cytoplasm and a medium, in motion: the effect ``fluids`` of a
``model: axisymmetric`` run (issue 36, item 3: the truth the 3D runs with fluids are held against).

On every evaluation of the shape's rate the boundary-integral map of
:mod:`cortex_ti.axisymmetric.stokes` (single and double layer by the rotated-pole quadrature,
spectral in the meridian's own discretisation) is rebuilt on the current shape and solved together
with the cortex's force balance (:func:`~cortex_ti.axisymmetric.stokes.with_fluids`): the unknowns
are the cortex's velocity and the fluids' traction jump ``Δf`` along the meridian, the cortex's
balance takes ``Δf`` as a force, and the two reciprocal identities weighted by the viscosities tie
``Δf`` to the velocity (the axisymmetric form of the 3D Dirichlet-to-Neumann map,
``docs/derivations/axisymmetric_fluids.md``). The medium fixes the translation along the axis
(no gauge) and the enclosed volume is kept by the inner flow.

Forces from outside, axisymmetric only: a body force ``body_force e_z`` on the cytoplasm (relative to
the medium: it sediments along the axis) and the far fields ``uniform`` (``U e_z``) and ``extension``
(``E (-r/2 e_r + z e_z)``). A shear is not axisymmetric: :func:`axisymmetric_fluids` refuses it.

The Jacobian the stiff integrator asks for is the exact complex-step one of the cortex and of the
coupling, with the layer matrices held at the current shape (their own dependence on the shape is
left out: a quasi-Newton Jacobian; the integrator's error control is on the exact rate, so this
costs Newton iterations, not accuracy).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
import scipy.linalg as sla

from .balance import lu_checked
from .dynamics import Dynamics
from .stokes import layers, with_fluids

__all__ = ["AxisymmetricFluids", "FluidDynamics", "axisymmetric_fluids"]


@dataclass(frozen=True)
class AxisymmetricFluids:
    """The fluids of an axisymmetric run: viscosities ``inner`` (>= 0) and ``outer`` (> 0), the
    cytoplasm's body force along z, and the far field (``'none'``, ``'uniform'`` with ``velocity``
    along z, ``'extension'`` with ``rate``)."""

    inner: float = 1.0
    outer: float = 1.0
    body_force: float = 0.0
    far_field: str = "none"
    velocity: float = 0.0
    rate: float = 0.0

    def __post_init__(self):
        if not (self.inner >= 0 and self.outer > 0):
            raise ValueError(f"the fluids' viscosities must be > 0 (outer), >= 0 (inner): {self.inner}, {self.outer}")
        if self.far_field not in ("none", "uniform", "extension"):
            raise ValueError(f"far field {self.far_field!r} is not axisymmetric (none, uniform or extension along z)")

    @property
    def symmetric(self) -> bool:
        """Whether the forces from outside keep the up-down symmetry (a body force or a flow along z does not)."""
        return self.body_force == 0 and not (self.far_field == "uniform" and self.velocity != 0)

    def far(self, r, z):
        """The far-field flow at the points, ``(u_r, u_z)`` stacked, or None for a medium at rest."""
        if self.far_field == "uniform":
            return np.concatenate([0.0 * r, self.velocity + 0.0 * z], axis=-1)
        if self.far_field == "extension":
            return np.concatenate([-0.5 * self.rate * r, self.rate * z], axis=-1)
        return None

    def as_dict(self) -> dict:
        return asdict(self)


def axisymmetric_fluids(fluid) -> AxisymmetricFluids | None:
    """The axisymmetric fluids of a scene's :class:`~cortex_ti.physics.model.Fluid` (anything with its
    attributes; None without the effect: None); ``ValueError`` in one line for what is not
    axisymmetric: a shear, a body force or a uniform flow with a component across the axis."""
    if fluid is None:
        return None
    bx, by, bz = (float(c) for c in fluid.body_force)
    if bx or by:
        raise ValueError(f"fluid.body_force = {[bx, by, bz]} is not along the axis z: the axisymmetric model needs it")
    far, vel = fluid.far_field, 0.0
    if far == "shear":
        raise ValueError("fluid.far_field.type = shear is not axisymmetric: use model: 3d (or uniform, extension)")
    if far == "uniform":
        ux, uy, vel = (float(c) for c in fluid.velocity)
        if ux or uy:
            raise ValueError(
                f"fluid.far_field.velocity = {[ux, uy, vel]} is not along the axis z: the axisymmetric model needs it"
            )
    return AxisymmetricFluids(float(fluid.inner), float(fluid.outer), bz, far, vel, float(fluid.rate))


class FluidDynamics(Dynamics):
    """:class:`~cortex_ti.axisymmetric.dynamics.Dynamics` with the fluids: the solve is the cortex's
    balance coupled to the boundary-integral map (unknowns ``[v_s, v_n, P(, lam), Δf_r, Δf_z]``,
    ``P`` the mean pressure jump, ``oint Δf . n dA = 0`` in the place of the volume's row, ``lam = 0``:
    the medium fixes the translation)."""

    def __init__(self, *args, fluids: AxisymmetricFluids, **kw):
        super().__init__(*args, **kw)
        self.fluids = fluids
        self._layers = None  # (S, D) of the last solve: the quasi-Newton Jacobian holds them

    def solve(self, y):
        g = self.geometry(y)
        A, b = self.system.assemble(g)
        f = self.fluids
        S, D = layers(self.sp, g["r"], g["z"], double=f.inner != f.outer)
        self._layers = (S, D)
        A2, b2 = with_fluids(
            A,
            b,
            self.sp,
            g,
            mu_in=f.inner,
            mu_out=f.outer,
            body_force=f.body_force,
            far_field=f.far(g["r"], g["z"]),
            layer_matrices=(S, D),
        )
        # the mean pressure jump stays the cortex's unknown P, the traction jump has no mean normal part
        # (S n = 0 holds only to the quadrature's accuracy: a pressure carried by Δf would leak volume at
        # that accuracy divided by the viscosity)
        n, w = self.n, self.sp.wR * g["r"] * g["h"]
        A2[n : 2 * n, 2 * n] = -1.0
        A2[2 * n, :] = 0.0
        A2[2 * n, self.system.nx : self.system.nx + n] = -w * g["zs"]
        A2[2 * n, self.system.nx + n :] = w * g["rs"]
        lu = lu_checked(A2)
        x = sla.lu_solve(lu, b2, check_finite=False)
        return g, x, lu

    def residual(self, x, g):
        """``A'(y) x - b'(y)`` of :func:`~cortex_ti.axisymmetric.stokes.with_fluids`, batched over the
        geometry (complex step), the layer matrices held at the last solve's shape."""
        sp, n, f = self.sp, self.n, self.fluids
        nx = self.system.nx
        xc = x[..., :nx].copy()
        xc[..., 2 * n + 1 :] = 0.0  # lam is not the cortex's unknown here (the medium fixes the translation)
        res = self.system.residual(xc, g)
        fr, fz = x[..., nx : nx + n], x[..., nx + n :]
        r, z, rs, zs = g["r"], g["z"], g["rs"], g["zs"]
        tan = (rs * fr + zs * fz) @ sp.Binv["O"].T
        tan[..., -1] = 0.0
        res[..., :n] = res[..., :n] + tan
        res[..., n : 2 * n] = res[..., n : 2 * n] + zs * fr - rs * fz - f.body_force * z
        res[..., 2 * n + 1 :] = x[..., 2 * n + 1 : nx]
        res[..., 2 * n] = ((rs * fz - zs * fr) * r * g["h"]) @ sp.wR
        vs, vn = x[..., :n], x[..., n : 2 * n]
        v = np.concatenate([rs * vs - zs * vn, zs * vs + rs * vn], axis=-1)
        S, D = self._layers
        bie = (f.inner + f.outer) * v + x[..., nx:] @ S.T / (4.0 * np.pi)
        if D is not None:
            bie = bie - (f.inner - f.outer) / (4.0 * np.pi) * (v @ D.T)
        far = f.far(r, z)
        if far is not None:
            bie = bie - 2.0 * f.outer * far
        return np.concatenate([res, bie], axis=-1)
