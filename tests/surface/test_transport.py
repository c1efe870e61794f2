"""Transport of nodal fields on the moving mesh (cortex_ti.surface.transport, dynamics.state,
dynamics.motion), against the truths derived in docs/derivations/transport.md: exact
conservation, a rigid rotation that brings a tracer back after a full turn, the decay of a
diffusing spherical harmonic, the rate of a carried tension at t = 0 on the sphere from the
exact sphere flow, and the state's invariance properties in whole runs."""

import numpy as np
import pytest

from cortex_ti.dynamics.motion import MotionContext, ale_velocity, conformal_distortion, volume_gradient
from cortex_ti.dynamics.state import FieldTransport, Rates, State
from cortex_ti.physics import fields as fieldreg
from cortex_ti.scene import load_scene
from cortex_ti.surface.mesh import icosphere
from cortex_ti.surface.transport import (
    DENSITY,
    PROPERTY,
    advective_rate,
    cotan_laplacian,
    dual_areas,
    dual_fluxes,
    implicit_diffusion_reaction,
    triangle_gradients,
)
from cortex_ti.truth.analytic import scene_solution
from cortex_ti.truth.sphere_exact import real_sph_harm

EPS = np.finfo(float).eps


def _rms(err, area):
    return float(np.sqrt(np.sum(err**2 * area) / area.sum()))


def test_fluxes_conserve_and_keep_constants_for_any_velocity():
    """sum_i dm_i/dt = 0 exactly (antisymmetric fluxes) and a uniform property has no rate, for a
    random velocity on a randomly perturbed mesh: bounds are round-off of sums of ~N terms."""
    rng = np.random.default_rng(3)
    m = icosphere(642)
    x = m.points * (1 + 0.05 * rng.standard_normal((642, 1)))
    u = rng.standard_normal((642, 3))
    c = 1 + rng.random(642)
    rate = advective_rate(c, DENSITY, x, m.faces, u)
    scale = np.abs(rate).sum()
    assert abs(rate.sum()) < 50 * EPS * scale
    const = advective_rate(np.full(642, 2.5), PROPERTY, x, m.faces, u)
    assert np.abs(const).max() < 50 * EPS * np.abs(u).max() * 2.5 / np.sqrt(dual_areas(x, m.faces).min())


def _flux_divergence(x, f, u):
    """div_h u of the dual cells: the net outflow sum_b F_ab of each node over its dual area."""
    flux, _ = dual_fluxes(x, f, u)
    a, b = f, np.roll(f, -1, axis=1)
    out = np.bincount(np.concatenate([a.ravel(), b.ravel()]), weights=np.concatenate([flux.ravel(), -flux.ravel()]))
    return out / dual_areas(x, f)


def test_a_carried_property_has_no_more_energy_growth_than_the_flow_compresses():
    """The continuum truth: a property carried on a fixed surface, dq/dt = -u . grad q, has
    d/dt (1/2) int q^2 dA = (1/2) int q^2 div u dA, whatever q. The scheme may only dissipate on top of it
    (docs/derivations/transport.md, "Energy"): a face value q_a + theta (q_b - q_a) (a upwind) adds
    -F_ab (1/2 - theta) (q_b - q_a)^2, and the limiter keeps theta in [0, 1/2].

    1. The scheme itself: sum_i A_i q_i dq_i/dt <= (1/2) sum_i A_i div_h u_i q_i^2 for 200 random fields and
       flows on a perturbed mesh, to round-off.
    2. Its linearisation at a rough field, where the limiter holds (nearly) every face at a bound, so the
       local linear map has the same energy identity with the bounds' theta (0 or 1/2): its numerical range,
       max over v of (v.A J v - (1/2) v.A div_h v) / v.A v, is <= 0 to the differencing's round-off
       (measured <= 2e-9). The earlier clip to [q_a, q_b] let faces sit at the downwind value (theta = 1):
       +1.1 to +1.7 there, the grid-scale anti-diffusion behind the furrow's crest modes."""
    rng = np.random.default_rng(7)
    m = icosphere(642)
    x = m.points * (1 + 0.05 * rng.standard_normal((642, 1)))
    area = dual_areas(x, m.faces)
    worst = -np.inf
    for _ in range(200):
        u = rng.standard_normal((642, 3))
        u -= np.einsum("nc,nc->n", u, x)[:, None] * x / np.einsum("nc,nc->n", x, x)[:, None]
        q = rng.standard_normal(642) + np.linspace(0.0, 3.0, 642) * rng.standard_normal()
        rate = advective_rate(q, PROPERTY, x, m.faces, u)
        lhs = np.sum(area * q * rate)
        rhs = 0.5 * np.sum(area * _flux_divergence(x, m.faces, u) * q * q)
        scale = np.sum(area * np.abs(q * rate)) + 1e-300
        worst = max(worst, (lhs - rhs) / scale)
    assert worst < 1e-12, worst

    m = icosphere(162)
    x = m.points * (1 + 0.05 * rng.standard_normal((162, 1)))
    area, tri, eps = dual_areas(x, m.faces), triangle_gradients(x, m.faces), 1e-7
    for _ in range(3):
        u = rng.standard_normal((162, 3))
        u -= np.einsum("nc,nc->n", u, x)[:, None] * x / np.einsum("nc,nc->n", x, x)[:, None]
        q = rng.standard_normal(162)
        jac = np.empty((162, 162))
        for j in range(162):
            dq = np.zeros(162)
            dq[j] = eps
            plus = advective_rate(q + dq, PROPERTY, x, m.faces, u, tri)
            jac[:, j] = (plus - advective_rate(q - dq, PROPERTY, x, m.faces, u, tri)) / (2 * eps)
        form = area[:, None] * jac
        form = 0.5 * (form + form.T) - np.diag(0.5 * area * _flux_divergence(x, m.faces, u))
        s = 1.0 / np.sqrt(area)
        top = np.linalg.eigvalsh(s[:, None] * form * s[None, :]).max()
        assert top < 1e-7, top


def test_cotan_laplacian_is_symmetric_with_zero_row_sums_and_diffuses_harmonics_at_their_rate():
    """K is symmetric with rows summing to 0 (mass kept by diffusion); the Rayleigh quotient
    Y^T K Y / Y^T M Y of Y_20 with the dual areas as mass converges to the Laplace-Beltrami
    eigenvalue l(l+1) = 6 of the unit sphere at second order. (Pointwise, -K Y / A is not
    consistent with the barycentric cells on the icosphere, whose areas differ from the Voronoi
    cells of the cotangent formula by up to 13 %: the scheme converges in the mean, as a lumped
    finite-element method, not node by node.)"""
    errs = []
    for n in (642, 2562):
        m = icosphere(n)
        k = cotan_laplacian(m.points, m.faces)
        assert abs(k - k.T).max() < 1e-12 * abs(k).max()
        assert np.abs(k @ np.ones(n)).max() < 1e-12 * abs(k).max()
        y = real_sph_harm(2, 0, m.points)
        area = dual_areas(m.points, m.faces)
        errs.append(abs((y @ (k @ y)) / np.sum(area * y * y) - 6.0))
    assert errs[1] < errs[0] / 3.0, errs  # second order: a factor ~4 per halving of h


@pytest.mark.slow
def test_implicit_diffusion_decays_a_harmonic_at_the_continuum_rate():
    """Diffusion alone of Y_lm on a fixed unit sphere decays as exp(-D l(l+1) t): backward Euler
    gives (1 + D l(l+1) dt)^-n in the continuum, so against that discrete-time truth what remains is
    the mesh's error, falling at second order; the time error itself is first order in dt."""
    D, t_end, steps, l = 0.1, 1.0, 100, 2
    dt = t_end / steps
    spatial = []
    for n in (642, 2562):
        m = icosphere(n)
        y = real_sph_harm(l, 0, m.points)
        c = y.copy()
        for _ in range(steps):
            c = implicit_diffusion_reaction(c, PROPERTY, m.points, m.faces, dt, diffusion=D)
        area = dual_areas(m.points, m.faces)
        discrete = (1 + D * l * (l + 1) * dt) ** -steps
        spatial.append(_rms(c - discrete * y, area) / _rms(y, area))
        exact = np.exp(-D * l * (l + 1) * t_end)
        # the time error of backward Euler, (lambda dt)^2/2 per step, summed: lambda^2 dt t / 2 of the mode
        time_error = 0.5 * (D * l * (l + 1)) ** 2 * dt * t_end * exact
        assert abs(discrete - exact) < 1.5 * time_error
    assert spatial[1] < spatial[0] / 3.0, spatial


def test_turnover_relaxes_a_density_to_its_target_and_keeps_mass_without_it():
    """Turnover -k (c - c0) alone: c0 + (c - c0) (1 + k dt)^-n exactly (backward Euler); diffusion
    alone keeps sum c A to round-off."""
    m = icosphere(162)
    rng = np.random.default_rng(0)
    c = 1 + 0.3 * rng.random(162)
    area = dual_areas(m.points, m.faces)
    out = implicit_diffusion_reaction(c * area, DENSITY, m.points, m.faces, 0.1, rate=2.0, target=1.0)
    np.testing.assert_allclose(out, 1 + (c - 1) / 1.2, rtol=0, atol=1e-14)
    out = implicit_diffusion_reaction(c * area, DENSITY, m.points, m.faces, 0.1, diffusion=3.0)
    assert abs(np.sum(out * area) - np.sum(c * area)) < 1e-13 * np.sum(c * area)


def _rotate_once(n):
    """A tracer bump carried by the rigid rotation about z over one full turn on a fixed mesh, Heun
    steps at a Courant number 0.4: the rms error against the initial field."""
    m = icosphere(n)
    x, f = m.points, m.faces
    bump = np.exp(-np.sum((x - [1.0, 0, 0]) ** 2, axis=1) / 0.25)
    h = np.mean(np.linalg.norm(x[f[:, 0]] - x[f[:, 1]], axis=1))
    steps = int(np.ceil(2 * np.pi / (0.4 * h)))
    dt = 2 * np.pi / steps
    u = np.cross([0.0, 0.0, 1.0], x)
    tri = triangle_gradients(x, f)
    tr = {"q": FieldTransport(PROPERTY)}
    s = State(x, {"q": bump}, f)
    zero = np.zeros_like(x)
    for _ in range(steps):
        r1 = Rates(zero, {"q": advective_rate(s.fields["q"], PROPERTY, x, f, u, tri)})
        pred = s.advanced(dt, r1, tr)
        r2 = Rates(zero, {"q": advective_rate(pred.fields["q"], PROPERTY, x, f, u, tri)})
        s = s.advanced(dt, 0.5 * (r1 + r2), tr)
    return _rms(s.fields["q"] - bump, dual_areas(x, f)), s.fields["q"]


@pytest.mark.slow
def test_a_rigid_rotation_brings_a_tracer_back_converging_with_the_mesh():
    """After a full turn the tracer is back, its error falling with h at the order of the limited
    upwind reconstruction: 2 where the field is smooth and monotone, 1 at its extrema where the
    limiter acts; measured 1.40 from 642 to 2562 nodes (docs/derivations/transport.md). Bounded:
    no new extrema beyond round-off below 0."""
    e1, _ = _rotate_once(642)
    e2, q = _rotate_once(2562)
    order = np.log2(e1 / e2)
    assert order > 1.3, (e1, e2, order)
    assert q.min() > -1e-6 and q.max() <= 1.0 + 1e-12


def test_carried_tension_rate_at_t0_is_minus_vt_grad_zeta_of_the_exact_sphere_flow():
    """On the unit sphere with zeta = Y_20 and the exact tangential flow (scene sphere_y20_tangential,
    analytic solution), the transport rate of a carried property is -v_t . grad zeta: the rms error
    converges at second order on the icospheres (supraconvergence; the pointwise error at the
    irregular nodes of the icosahedron's seams is first order)."""
    settings = load_scene("sphere_y20_tangential").settings
    rms, peak = [], []
    for n in (642, 2562):
        m = icosphere(n)
        x = m.points
        v = scene_solution(settings, x)
        vt = v - np.einsum("nc,nc->n", v, x)[:, None] * x
        zeta = real_sph_harm(2, 0, x)
        grad = np.sqrt(5 / (4 * np.pi)) * 3 * x[:, 2:3] * (np.array([0.0, 0, 1]) - x[:, 2:3] * x)
        exact = -np.einsum("nc,nc->n", vt, grad)
        rate = advective_rate(zeta, PROPERTY, x, m.faces, vt)
        area = dual_areas(x, m.faces)
        rms.append(_rms(rate - exact, area) / _rms(exact, area))
        peak.append(np.abs(rate - exact).max() / np.abs(exact).max())
    assert np.log2(rms[0] / rms[1]) > 1.5, rms
    assert np.log2(peak[0] / peak[1]) > 0.9, peak


def test_simulation_rate_of_a_carried_tension_matches_the_exact_flow():
    """The same through a simulation (rayleigh_p1 velocity, tension_transport: material): its field
    rate at t = 0 converges to -v_t . grad zeta (the velocity's own error is second order)."""
    from cortex_ti.simulation.core import Simulation

    errs = []
    for n in (642, 2562):
        scene = load_scene(
            "sphere_y20_tangential",
            [
                f"mesh.nodes={n}",
                "numerics.formulation=rayleigh_p1",
                "numerics.fit=quadratic",
                "tension_transport=material",
            ],
        )
        sim = Simulation(scene)
        ev = sim.evaluate(sim.mesh.points)
        x = sim.mesh.points
        v = scene_solution(scene.settings, x)
        vt = v - np.einsum("nc,nc->n", v, x)[:, None] * x
        grad = np.sqrt(5 / (4 * np.pi)) * 3 * x[:, 2:3] * (np.array([0.0, 0, 1]) - x[:, 2:3] * x)
        exact = -np.einsum("nc,nc->n", vt, grad)
        area = dual_areas(x, sim.mesh.faces)
        errs.append(_rms(ev.field_rates["prescribed_tension"] - exact, area) / _rms(exact, area))
    assert errs[1] < errs[0] / 2.5, errs


def test_ale_velocity_is_tangential_zero_on_the_reference_and_lowers_the_distortion():
    """The ALE mesh velocity has the normal part v_n n exactly, no tangential part on undistorted
    triangles, and on a distorted mesh it keeps the triangulated volume and decreases the
    distortion energy (a gradient flow, projected volume-neutral: dE/dt = -sum g . w_t <= 0)."""
    m = icosphere(642)
    ctx = MotionContext(m.faces, m.points, ale_time=0.1)
    rng = np.random.default_rng(1)
    v = rng.standard_normal((642, 3))
    n = m.points
    w = ale_velocity(v, n, m.points, ctx)
    np.testing.assert_allclose(w, np.einsum("nc,nc->n", v, n)[:, None] * n, rtol=0, atol=1e-13)
    x = m.points + 0.02 * rng.standard_normal((642, 3))
    x /= np.linalg.norm(x, axis=1)[:, None]
    normal = x
    w = ale_velocity(np.zeros_like(x), normal, x, ctx)
    assert np.abs(np.einsum("nc,nc->n", w, normal)).max() < 1e-14
    vg = volume_gradient(x, m.faces)  # and it does not change the triangulated volume
    assert abs(np.sum(vg * w)) < 1e-13 * np.sum(np.abs(vg * w))
    e0 = conformal_distortion(x, ctx).sum()
    e1 = conformal_distortion(x + 1e-3 * w, ctx).sum()
    assert e1 < e0


@pytest.fixture
def tracer_field():
    """A density registered for the test only: carried by the material, initial 1 + x."""
    spec = fieldreg.FieldSpec(
        name="tracer",
        kind=DENSITY,
        present=lambda s: True,
        initial=lambda s, p: 1.0 + p[:, 0],
        carried=lambda s: True,
        attrs=(("units", "1"), ("long_name", "test tracer")),
    )
    fieldreg.register_field(spec)
    yield spec
    del fieldreg.FIELDS["tracer"]


@pytest.mark.parametrize("motion", ["normal", "lagrangian", "ale"])
def test_a_density_total_is_kept_over_a_furrow_run_with_every_motion(tracer_field, tmp_path, motion):
    """sum c A of a carried density is constant to round-off over a whole (short) furrow run with
    each mesh motion: the fluxes are antisymmetric and the dilution is the change of the dual areas.
    The trajectory stores the field as a variable of its own, and the run resumes from it."""
    import xarray as xr

    from cortex_ti.simulation.core import Simulation

    sets = [
        "mesh.nodes=162",
        "time.t_end=0.2",
        "time.save_every=0.05",
        f"mesh.motion={motion}",
        "tension_transport=material",
    ]
    sim = Simulation(load_scene("furrow_p4_a1", sets))
    sim.run(tmp_path / "r.h5", progress=False)
    ds = xr.load_dataset(tmp_path / "r.h5", engine="h5netcdf")
    c = ds["tracer"].values
    totals = [np.sum(c[k] * dual_areas(ds.points.values[k], ds.triangles.values)) for k in range(len(ds.time))]
    assert len(totals) == 5
    assert np.ptp(totals) < 1e-12 * totals[0]
    if motion != "normal":
        assert np.ptp(c[-1]) > 0  # it moved


def test_lagrangian_motion_is_the_material_tension_and_keeps_it_on_the_nodes(tmp_path):
    """With lagrangian motion the nodes are material points: the carried tension stays exactly at
    its nodes' initial values, and tension_transport makes no difference."""
    import xarray as xr

    from cortex_ti.simulation.core import Simulation

    base = ["mesh.nodes=162", "time.t_end=0.1", "mesh.motion=lagrangian"]
    out = {}
    for tt in ("nodes", "material"):
        sim = Simulation(load_scene("furrow_p4_a1", base + [f"tension_transport={tt}"]))
        sim.run(tmp_path / f"{tt}.h5", progress=False)
        out[tt] = xr.load_dataset(tmp_path / f"{tt}.h5", engine="h5netcdf")
    a, b = out["nodes"], out["material"]
    assert np.array_equal(a.points.values, b.points.values)
    assert np.array_equal(a.active_stress.values[-1], a.active_stress.values[0])
    # the nodes moved tangentially: more than their normal motion
    d = a.points.values[-1] - a.points.values[0]
    n0 = a.points.values[0] / np.linalg.norm(a.points.values[0], axis=1)[:, None]
    assert np.abs(d - np.einsum("nc,nc->n", d, n0)[:, None] * n0).max() > 1e-4


def test_resume_restores_every_field(tracer_field, tmp_path):
    """A run resumed from a frame continues with that frame's whole state (positions, the carried
    tension, the tracer): it reproduces the uninterrupted run. Regression check of the code against
    itself. The resumed run's first solves start without the factorisation the uninterrupted run
    reuses, so each solve may differ within the solver's tolerance (solver.rtol, relative): the
    bound is that tolerance times the steps since the resume times the field's scale."""
    import shutil

    import xarray as xr

    from cortex_ti.simulation.core import Simulation

    # a one-step scheme (bdf2 restarts on resume, and differs by its time error)
    sets = ["mesh.nodes=162", "time.save_every=0.05", "mesh.motion=ale", "tension_transport=material"]
    sets += ["time.scheme=euler", "time.dt=5e-3"]
    Simulation(load_scene("furrow_p4_a1", sets + ["time.t_end=0.1"])).run(tmp_path / "a.h5", progress=False)
    shutil.copy(tmp_path / "a.h5", tmp_path / "b.h5.partial")
    whole = Simulation(load_scene("furrow_p4_a1", sets + ["time.t_end=0.2"]))
    whole.run(tmp_path / "c.h5", progress=False)
    resumed = Simulation(load_scene("furrow_p4_a1", sets + ["time.t_end=0.2"]))
    resumed.run(tmp_path / "b.h5", resume=True, progress=False)
    b = xr.load_dataset(tmp_path / "b.h5", engine="h5netcdf")
    c = xr.load_dataset(tmp_path / "c.h5", engine="h5netcdf")
    assert b.sizes["time"] == c.sizes["time"] == 5, (b.time.values, c.time.values)
    rtol = whole.settings.solver.rtol
    steps = round(0.1 / whole.settings.time.dt)
    for var in ("points", "active_stress", "tracer"):
        scale = np.abs(c[var].values).max()
        np.testing.assert_allclose(b[var].values, c[var].values, rtol=0, atol=rtol * steps * scale)
    assert np.ptp(b.active_stress.values[-1] - b.active_stress.values[0]) > 0  # the tension moved


def test_the_translation_gauge_is_a_rigid_translation_of_a_material_cortex(tmp_path):
    """With lagrangian motion the cortex is a material: a rigid translation of the velocity carries
    the shape and everything on it along, so the two gauges of the free translation (zero mean
    velocity, the centroid held) give the same shapes up to a rigid translation, to the solver's
    precision, on a scene without up-down symmetry (zeta = 1 + 0.3 Y_20 + 0.3 Y_30), where the
    translation is not zero. The bound: solver.rtol times the steps times the shape's size. Fixed
    steps (euler): an adaptive scheme's error estimates differ between the gauges by round-off, and
    so may its step sequences, by a time error (1e-6 at 162 nodes with bdf2's default tolerance).

    With the pressure on the exact volume gradient (numerics.pressure_weights: exact) and the active
    force the exact gradient of the energy (numerics.active_force: gradient) the discrete
    forces sum to zero exactly (the energy and the volume are translation invariant), so the gauge
    rows' multipliers vanish and the two systems have the same solution up to U; with petrov the
    pressure pushes on the Meyer areas, whose net force is O(h^2) and is taken up differently by
    each gauge. Exact only without the two terms whose discretisation is not invariant under a
    rigid translation: the bending viscosity (its lumped beta_0 v_n^2 and the fitted curvature see the
    translation's U . n, README) and the semi-implicit tension (its drag dt zeta |grad v_n|^2 sees
    it too, an O(dt) term): with them the shapes differ by ~0.5 % of the translation at 162 nodes."""
    import copy

    import xarray as xr

    from cortex_ti.scene import scene_from_dict
    from cortex_ti.simulation.core import Simulation

    base = copy.deepcopy(
        load_scene(
            "furrow_p4_a1",
            [
                "mesh.nodes=162",
                "time.t_end=0.3",
                "mesh.motion=lagrangian",
                "time.implicit_tension=false",
                "time.scheme=euler",
                "numerics.pressure_weights=exact",
                "numerics.active_force=gradient",
            ],
        ).data
    )
    base["effects"] = [e for e in base["effects"] if e != "bending_viscosity"]
    base["viscosity"].update(bending=0.0, bending_bulk=0.0)
    base["active_stress"] = [
        {
            "type": "harmonics",
            "terms": [
                {"l": 0, "m": 0, "coeff": float(np.sqrt(4 * np.pi))},
                {"l": 2, "m": 0, "coeff": 0.3},
                {"l": 3, "m": 0, "coeff": 0.3},
            ],
        }
    ]
    pts = {}
    for gauge in ("mean_velocity", "centroid"):
        data = copy.deepcopy(base)
        data["translation"] = gauge
        sim = Simulation(scene_from_dict(data))
        sim.run(tmp_path / f"{gauge}.h5", progress=False)
        pts[gauge] = xr.load_dataset(tmp_path / f"{gauge}.h5", engine="h5netcdf").points.values
    d = pts["mean_velocity"] - pts["centroid"]
    shift = d.mean(axis=1)
    assert np.abs(shift[-1]).max() > 1e-4  # the gauges do differ by a translation
    steps = round(0.3 / sim.settings.time.dt)
    assert np.abs(d - shift[:, None, :]).max() < sim.settings.solver.rtol * steps * 10


def _myosin_scene(tmp_path, **myosin):
    import yaml

    data = {
        "name": "myosin",
        "mesh": {"nodes": 162},
        "fields": {
            "myosin": {
                "c0": 1.0,
                "initial": [{"type": "harmonics", "terms": [{"l": 2, "m": 0, "coeff": 0.1}]}],
                **myosin,
            }
        },
        "active_stress": [],
        "effects": [
            "active_stress",
            "shear_viscosity",
            "bulk_viscosity",
            "normal_balance",
            "incompressibility",
            "shape_evolution",
        ],
        "time": {"dt": 0.005, "t_end": 0.2, "save_every": 0.05},
    }
    path = tmp_path / "myosin.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.parametrize("turnover", [0.0, 2.0])
def test_myosin_total_is_kept_and_turns_over_as_dM_dt_says(tmp_path, turnover):
    """The myosin field (fields.myosin): without turnover its total sum c A is kept to round-off over
    a run (diffusion and transport conserve it); with turnover k it follows the backward-Euler step
    of dM/dt = -k (M - c0 A(t)) exactly, M_{n+1} = (M_n + dt k c0 A_{n+1}) / (1 + dt k)."""
    import xarray as xr

    from cortex_ti.scene import load_scene as load
    from cortex_ti.simulation.core import Simulation

    sim = Simulation(load(_myosin_scene(tmp_path, diffusion=0.1, turnover=turnover)))
    sim.run(tmp_path / "m.h5", progress=False)
    ds = xr.load_dataset(tmp_path / "m.h5", engine="h5netcdf")
    f = ds.triangles.values
    mass = np.array([np.sum(ds.myosin.values[k] * dual_areas(ds.points.values[k], f)) for k in range(len(ds.time))])
    if turnover == 0.0:
        assert np.ptp(mass) < 1e-12 * mass[0]
    else:
        # between frames 10 steps; the area changes little, so the closed form with A(t) at the frame
        # times bounds the difference by k dt |dA| over the interval
        area = np.array([dual_areas(ds.points.values[k], f).sum() for k in range(len(ds.time))])
        dt, steps = 0.005, 10
        for k in range(len(mass) - 1):
            expect = mass[k]
            for _ in range(steps):
                expect = (expect + dt * turnover * area[k + 1]) / (1 + dt * turnover)
            assert abs(mass[k + 1] - expect) < turnover * steps * dt * abs(area[k + 1] - area[k]) + 1e-12 * mass[0]
    # the tension is the linear law of the density
    np.testing.assert_allclose(ds.active_stress.values, ds.myosin.values, rtol=0, atol=1e-14)


def test_myosin_bad_input_is_one_line(tmp_path):
    """A negative diffusion, and a myosin noise under the axisymmetric model (it varies about z), are
    refused naming the key."""
    import subprocess
    import sys

    bad = _myosin_scene(tmp_path, diffusion=-1.0)
    out = subprocess.run([sys.executable, "-m", "cortex_ti.cli", "check", str(bad)], capture_output=True, text=True)
    assert out.returncode == 2 and "fields.myosin.diffusion" in out.stderr and "Traceback" not in out.stderr
    ok = _myosin_scene(tmp_path)
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "cortex_ti.cli",
            "check",
            str(ok),
            "--set",
            "model=axisymmetric",
            "--set",
            "fields.myosin.noise.amplitude=0.01",
        ],
        capture_output=True,
        text=True,
    )
    assert out.returncode == 2 and "fields.myosin.noise" in out.stderr and len(out.stderr.strip().splitlines()) == 1
