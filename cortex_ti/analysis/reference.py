"""Comparison with the axisymmetric reference runs (shipped in cortex_ti/data/axisym).

The reference (its README) gives, for the furrow of paper Fig. 5 (p = 8,
zeta_hat = 1): pole and furrow radius every 0.01 t_a, and the flow along the
meridian at t = 0, 0.1, 1.5, 3 (columns z, r, s, ``|v_t|``, signed v_t, v_n, zeta).
Its pole radius is half the pole-to-pole distance and its furrow radius the
cylindrical radius at the equator, the definitions of :mod:`cortex_ti.analysis.diagnostics`.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import CortexError

#: The reference shipped with the package (``cortex_ti/data/axisym``, see its README)
DEFAULT_DIR = Path(__file__).resolve().parent.parent / "data" / "axisym"
PROFILE_TIMES = (0.0, 0.1, 1.5, 3.0)


def reference_dir(path=None) -> Path:
    """The reference folder: ``path``, ``$CORTEX_TI_AXISYM`` or the one shipped in the package."""
    folder = Path(path or os.environ.get("CORTEX_TI_AXISYM", DEFAULT_DIR))
    if not (folder / "caseA_p8_zh1_radii_vs_time.csv").exists():
        raise CortexError(f"no axisymmetric reference in '{folder}' (set CORTEX_TI_AXISYM)")
    return folder


def load_radii(path=None) -> dict[str, np.ndarray]:
    """``t``, ``pole_radius``, ``furrow_radius`` of the reference (p = 8, zeta_hat = 1)."""
    data = np.genfromtxt(reference_dir(path) / "caseA_p8_zh1_radii_vs_time.csv", delimiter=",", names=True)
    return {
        "t": data["t_over_ta"],
        "pole_radius": data["pole_radius_over_R0"],
        "furrow_radius": data["furrow_radius_over_R0"],
    }


def load_profile(t: float, path=None) -> dict[str, np.ndarray]:
    """The reference flow along the meridian at time ``t`` (one of :data:`PROFILE_TIMES`)."""
    name = f"caseA_p8_zh1_velocity_t{t:.1f}.csv"
    data = np.genfromtxt(reference_dir(path) / name, delimiter=",", names=True)
    return {"z": data["z_over_R0"], "r": data["r_over_R0"], "abs_vt": data["abs_vt_over_va"], "vn": data["vn_over_va"]}


#: The ring of the reference run (its README): the furrow of paper Fig. 5.
REFERENCE_RING = {"type": "ring", "zeta0": 1.0, "amplitude": 1.0, "sigma": 10.0, "p": 8.0, "axis": [0.0, 0.0, 1.0]}


def matches_reference(settings) -> bool:
    """Whether a scene (its :class:`~cortex_ti.scene.RunSettings`) is the reference's problem: the
    ring of Eq. 59 with p = 8, zeta_hat = 1, sigma = 10 on the unit sphere, eta_s = eta_b = 1, no
    initial deformation, shape evolution on (the bending-viscosity regularisation may differ:
    README)."""
    m, v = settings.mesh, settings.viscosity
    if not settings.dynamic or m.transform is not None or m.file is not None or m.shear != 0.0 or m.radius != 1.0:
        return False
    if (v.shear, v.bulk) != (1.0, 1.0) or len(settings.patterns) != 1:
        return False
    ring = settings.patterns[0]
    if float(ring.get("center", np.pi / 2)) != np.pi / 2:  # the reference's ring is on the equator
        return False
    return ring.get("type") == "ring" and all(
        np.allclose(np.asarray(ring.get(k, want), dtype=float), np.asarray(want, dtype=float), rtol=1e-12, atol=1e-12)
        for k, want in REFERENCE_RING.items()
        if k != "type"
    )


def radii_deviation(times, pole, furrow, path=None) -> dict[str, float]:
    """Largest ``|3D - reference|`` of pole and furrow radius at the frame times (R0).

    Only frame times that fall on the reference's 0.01 grid are compared.
    """
    ref = load_radii(path)
    idx = np.rint(np.asarray(times) / 0.01).astype(int)
    ok = (np.abs(np.asarray(times) - idx * 0.01) < 1e-9) & (idx < len(ref["t"]))
    if not ok.any():
        raise CortexError("no frame time falls on the reference's 0.01 t_a grid")
    dp = np.abs(np.asarray(pole)[ok] - ref["pole_radius"][idx[ok]])
    df = np.abs(np.asarray(furrow)[ok] - ref["furrow_radius"][idx[ok]])
    return {
        "pole": float(dp.max()),
        "furrow": float(df.max()),
        "t_pole": float(np.asarray(times)[ok][dp.argmax()]),
        "t_furrow": float(np.asarray(times)[ok][df.argmax()]),
        "frames": int(ok.sum()),
    }


def profile_deviation(points, velocity, normals, t: float, path=None) -> dict[str, float]:
    """Deviation of v_n(z) and ``|v_t|(z)`` at the nodes from the reference profile at ``t``.

    The reference is interpolated in z (single-valued along the meridian). Returns
    the largest and rms deviations in units of v_a = R0 / t_a.
    """
    ref = load_profile(t, path)
    order = np.argsort(ref["z"])
    z = points[:, 2]
    vn = np.einsum("nc,nc->n", velocity, normals)
    vt = np.linalg.norm(velocity - vn[:, None] * normals, axis=1)
    vn_ref = np.interp(z, ref["z"][order], ref["vn"][order])
    vt_ref = np.interp(z, ref["z"][order], ref["abs_vt"][order])
    return {
        "vn_max": float(np.abs(vn - vn_ref).max()),
        "vn_rms": float(np.sqrt(np.mean((vn - vn_ref) ** 2))),
        "vt_max": float(np.abs(vt - vt_ref).max()),
        "vt_rms": float(np.sqrt(np.mean((vt - vt_ref) ** 2))),
        "vn_scale": float(np.abs(ref["vn"]).max()),
        "vt_scale": float(np.abs(ref["abs_vt"]).max()),
    }
