"""The rail vehicle over a track irregularity (docs/track.md): the exported rail_vehicle_track FMU,
whose rails move on driven vertical joints, and the track FMU built here with pythonfmu from
cosim/track/track_irregularity.py, connected by cosim/track/SystemStructure.ssd and run by fmpy
(cosim/run_system.py) and libcosim (cosim/run_libcosim.py). The co-simulated runs are short (1 s
at 120 km/h on FRA class 4 track); the table of docs/track.md comes from cosim/track_study.py.
"""

import math
import sys
import zipfile

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu

from conftest import ROOT, Instance

pytest.importorskip("pythonfmu")  # ./run_tests.sh installs both
pytest.importorskip("libcosimpy")
sys.path.insert(0, str(ROOT))
from cosim import build_track, ride, run_system, track_study  # noqa: E402
from cosim.ssp import algebraic_loops, direct_feedthrough, read_system  # noqa: E402
from cosim.track import track_irregularity as track  # noqa: E402

WHEELS = ride.WHEELS
RUN_TIME = 1.0
SPEED_KMH = 120.0
H = 0.001  # the SSD's communication step
RAIL_HEAD_MASS = 10.0  # fmu/rail_vehicle_track/scene.toml
BODIES = ["car"] + [f"{p}_{s}" for p in ("bolster", "bogie") for s in ("fl", "fr", "rl", "rr")] + [
    f"wheel_{w}" for w in WHEELS
]
OUTPUTS = (
    track_study.OUTPUTS
    + [f"vehicle.railhead_{w}.r[3]" for w in WHEELS]
    + [f"vehicle.rail_{w}.force" for w in WHEELS]
    + [f"vehicle.{b}.v[3]" for b in BODIES]
    + ["track.profile_rms"]
)


@pytest.fixture(scope="module")
def track_fmu(tmp_path_factory):
    return build_track.build_track_fmu(tmp_path_factory.mktemp("track") / "track_irregularity.fmu")


@pytest.fixture(scope="module")
def ssp(fmus, track_fmu, tmp_path_factory):
    out = tmp_path_factory.mktemp("ssp") / "rail_vehicle_track.ssp"
    return track_study.pack_variant(out, SPEED_KMH, 4, vehicle=fmus["rail_vehicle_track"], track_fmu=track_fmu)


@pytest.fixture(scope="module")
def fmpy_run(ssp):
    return track_study.run(ssp, "fmpy", RUN_TIME, OUTPUTS)


@pytest.fixture(scope="module")
def libcosim_run(ssp):
    return track_study.run(ssp, "libcosim", RUN_TIME, OUTPUTS)


@pytest.fixture
def track_instance(track_fmu, tmp_path):
    """Factory of track FMU instances, freed without unloading the library (run_system.free)."""
    with zipfile.ZipFile(track_fmu) as z:
        z.extractall(tmp_path)
    made = []

    def _make(start_values=None):
        inst = Instance(tmp_path, "track")
        made.append(inst)
        inst.init(start_values or {})
        return inst

    yield _make
    for inst in made:
        run_system.free(inst.slave, inst.md)


def masses(fmu):
    md = read_model_description(str(fmu))
    return {v.name[: -len(".mass")]: float(v.start) for v in md.modelVariables if v.name.endswith(".mass")}


# --------------------------------------------------------------------------------------
# The track FMU alone
# --------------------------------------------------------------------------------------


def test_track_fmu_passes_fmpy_validation_and_does_not_feed_through(track_fmu):
    assert validate_fmu(str(track_fmu)) == []
    feedthrough = direct_feedthrough(track_fmu)
    assert set(feedthrough) == {f"{s}_{w}" for s in ("z", "zd", "zdd") for w in WHEELS}
    assert all(inputs == set() for inputs in feedthrough.values())
    units = {v.name: v.unit for v in read_model_description(str(track_fmu)).modelVariables}
    assert (units["x_fl1"], units["v_fl1"], units["z_fl1"], units["zd_fl1"], units["zdd_fl1"]) == (
        "m", "m/s", "m", "m/s", "m/s2")


def fra_variance(track_class, wavelength_min, wavelength_max):
    """The integral of the FRA spectrum over the band, in closed form [m^2]:
    k A Ωc² ∫ dΩ / (Ω² (Ω² + Ωc²)) = k A [1/Ω1 − 1/Ω2 − (atan(Ω2/Ωc) − atan(Ω1/Ωc)) / Ωc]."""
    o1, o2, oc = 2 * math.pi / wavelength_max, 2 * math.pi / wavelength_min, track.FRA_OMEGA_C
    a = track.FRA_K * track.FRA_CLASSES[track_class] * 1e-4
    return a * (1 / o1 - 1 / o2 - (math.atan(o2 / oc) - math.atan(o1 / oc)) / oc)


@pytest.mark.parametrize("track_class", [4, 6])
def test_profile_rms_is_the_spectrum_integrated_over_the_band(track_instance, track_class):
    inst = track_instance({"track_class": track_class})
    exact = math.sqrt(fra_variance(track_class, 1.5, 120.0))
    # the harmonics sample the spectrum at the mid points of 1000 intervals (the midpoint rule)
    assert inst.get("profile_rms") == pytest.approx(exact, rel=2e-3)


def step_track(inst, x, v, h=H):
    for w in WHEELS:
        inst.set(f"x_{w}", x)
        inst.set(f"v_{w}", v)
    inst.step(h)
    return inst.get("z_fl1"), inst.get("zd_fl1"), inst.get("zdd_fl1")


def test_rate_and_acceleration_are_the_profile_derivatives_along_the_wheel_path(track_instance):
    # At constant speed v the outputs for t + h are z(x + v h), z'(x + v h) v, z''(x + v h) v²;
    # compared with central differences of z along the track (fade-in region included).
    v, d = 20.0, 1e-3
    inst = track_instance()
    for x in (25.0, 80.0, 333.3):
        z0, zd, zdd = step_track(inst, x - v * H, v)
        zp, _, _ = step_track(inst, x + d - v * H, v)
        zm, _, _ = step_track(inst, x - d - v * H, v)
        slope, curvature = (zp - zm) / (2 * d), (zp - 2 * z0 + zm) / d**2
        assert zd / v == pytest.approx(slope, rel=1e-5, abs=1e-9)
        assert zdd / v**2 == pytest.approx(curvature, rel=1e-3, abs=1e-6)


def test_acceleration_of_the_wheel_enters_through_the_slope(track_instance):
    # Speeds 20 then 21 m/s over h: a = 1000 m/s²; outputs at x + v h + a h²/2 with speed v + a h:
    # zdd = z'' (v + a h)² + z' a.
    a_inst, b_inst = track_instance(), track_instance()
    x0, h = 50.0, H
    step_track(a_inst, x0, 20.0)
    z, zd, zdd = step_track(a_inst, x0 + 0.02, 21.0)
    a = (21.0 - 20.0) / h
    x_next, v_next = x0 + 0.02 + 21.0 * h + 0.5 * a * h * h, 21.0 + a * h
    step_track(b_inst, x_next - v_next * h, v_next)  # the same point at constant speed
    z_b, zd_b, zdd_b = b_inst.get("z_fl1"), b_inst.get("zd_fl1"), b_inst.get("zdd_fl1")
    assert z == pytest.approx(z_b, rel=1e-12, abs=1e-15)
    assert zd == pytest.approx(zd_b, rel=1e-12)
    assert zdd == pytest.approx(zdd_b + (zd_b / v_next) * a, rel=1e-9)


def test_flat_before_the_fade_and_reproducible_by_seed(track_instance):
    z, zd, zdd = step_track(track_instance(), 9.0, 0.0)
    assert (z, zd, zdd) == (0.0, 0.0, 0.0)  # up to fade_start (10 m) the rails are flat
    same = [step_track(track_instance({"seed": 7}), 200.0, 30.0) for _ in range(2)]
    other = step_track(track_instance({"seed": 8}), 200.0, 30.0)
    assert same[0] == same[1] and other != same[0]
    assert step_track(track_instance({"amplitude_scale": 0.0}), 200.0, 30.0) == (0.0, 0.0, 0.0)


# --------------------------------------------------------------------------------------
# The system
# --------------------------------------------------------------------------------------


def test_ssd_connects_every_wheel_to_its_rail(ssp, tmp_path):
    system = read_system(ssp, tmp_path)
    assert set(system.components) == {"vehicle", "track"}
    assert system.step_size == H
    conns = {(c.start_element, c.start_connector, c.end_element, c.end_connector) for c in system.connections}
    expected = set()
    for w in WHEELS:
        expected |= {("vehicle", f"wheel_{w}.r[1]", "track", f"x_{w}"), ("vehicle", f"wheel_{w}.v[1]", "track", f"v_{w}")}
        expected |= {("track", f"{s}_{w}", "vehicle", f"rail_{w}.{q}") for s, q in (("z", "q"), ("zd", "qd"), ("zdd", "qdd"))}
    assert conns == expected
    vehicle = system.components["vehicle"].parameters
    assert vehicle["car.velocity[1]"] == pytest.approx(SPEED_KMH / 3.6, rel=1e-15)
    assert vehicle["wheel_fl1.angular_velocity[2]"] == pytest.approx(SPEED_KMH / 3.6 / 0.46, rel=1e-15)
    assert system.components["track"].parameters["track_class"] == 4
    # The vehicle's outputs declare direct dependencies on its motion inputs, the track's on
    # nothing: no algebraic loop.
    assert algebraic_loops(system) == []


def test_engines_agree_bit_for_bit(fmpy_run, libcosim_run):
    # Same algorithm (Jacobi, the same communication times, libcosim's initial propagation and
    # sampling), deterministic FMUs: every recorded column equal, inputs and outputs.
    assert len(fmpy_run["time"]) == round(RUN_TIME / H) + 1
    assert track_study.identical(fmpy_run, libcosim_run) == []
    assert set(fmpy_run) == set(libcosim_run)


def test_the_vehicle_sees_the_rail_heights_the_track_gives(fmpy_run):
    r = fmpy_run
    moved = 0
    for w in WHEELS:
        z, zd, zdd = r[f"track.z_{w}"], r[f"track.zd_{w}"], r[f"track.zdd_{w}"]
        # the values the vehicle got are the track's outputs of the same communication point
        # (recorded before the master set them: one point later in the vehicle's input columns)
        for s, q in ((z, "q"), (zd, "qd"), (zdd, "qdd")):
            assert np.array_equal(r[f"vehicle.rail_{w}.{q}"][1:], s[:-1])
        # and its rail head moved as they say: z + zd h + zdd h²/2 at the end of each step
        end = z[:-1] + zd[:-1] * H + 0.5 * zdd[:-1] * H * H
        assert np.max(np.abs(r[f"vehicle.railhead_{w}.r[3]"][1:] - end)) <= 1e-13
        moved = max(moved, np.max(np.abs(z)))
    assert moved > 1e-3  # the rails did move (mm)


def test_rail_drive_force_is_newtons_law_for_the_rail_head(fmpy_run):
    # The drive holds the rail head against the wheel's load and moves it: force = Q + m (z̈ + g)
    # (the vertical acceleration over the step that ended at the sample is the qdd set before it).
    r = fmpy_run
    for w in WHEELS:
        q = r[f"vehicle.contact_{w}.force"][1:]
        newton = q + RAIL_HEAD_MASS * (r[f"vehicle.rail_{w}.qdd"][1:] + ride.G)
        assert np.max(np.abs(r[f"vehicle.rail_{w}.force"][1:] - newton)) <= 1e-9 * 53.5e3


def test_rail_forces_change_the_vehicles_vertical_momentum(fmpy_run, fmus):
    # Newton for the whole vehicle: the wheel-rail forces and gravity are the only vertical forces
    # on it, so ∫ (ΣQ − M g) dt = ΔP_z (trapezoidal rule over the 1 ms samples). The samples are
    # the forces at the end of each step, before the rails move on to the track's next values
    # (jumps of up to 1e-7 m, about 100 N of wheel load): the quadrature misses them. Measured:
    # 3.1e-5 of M g T at the 1 ms step, ten times less at 0.5 ms; a missing force of 10 kg
    # weight would make 2.3e-4.
    r = fmpy_run
    m = masses(fmus["rail_vehicle_track"])
    p = sum(m[b] * r[f"vehicle.{b}.v[3]"] for b in BODIES)
    weight = sum(m[b] for b in BODIES) * ride.G
    net = sum(r[f"vehicle.contact_{w}.force"] for w in WHEELS) - weight
    impulse = np.concatenate([[0.0], np.cumsum(0.5 * (net[1:] + net[:-1]) * H)])
    scale = weight * RUN_TIME
    error = np.max(np.abs(impulse - (p - p[0])))
    print(f"|impulse - ΔP| <= {error:.3e} N s = {error / scale:.2e} of M g T; |ΔP| up to {np.max(np.abs(p - p[0])):.0f} N s")
    assert error <= 5e-5 * scale


def test_energy_balance_holds_with_the_rails_moving(fmpy_run, fmus):
    mass = track_study.vehicle_mass(fmus["rail_vehicle_track"])
    m = ride.evaluate(fmpy_run, 0.5, mass)
    assert fmpy_run["vehicle.energy.input_work"][-1] != 0.0  # the drives work
    assert m["energy_drift"] <= 1e-6
    assert not m["unloaded"] and 0.3 < m["q_min"] < 1.0 < m["q_max"] < 2.0


def test_flat_track_runs_as_the_bundled_rail_vehicle(unzipped, make_instance):
    # The same vehicle on rails at rest: the car body's motion equal to solver tolerance; the
    # wheel loads within 1e-3 of Q0 (the side frames here may pitch, the bundled ones may not: the
    # two wheels of a frame share its load a little differently while the car body pitches).
    # Both at the track scene's tolerances (the bundled rail vehicle's own, rtol 4e-6, are
    # chosen for 1e-6 of its range of motion: 2.9e-7 m here).
    a = make_instance(unzipped["rail_vehicle_track"], "track")
    b = make_instance(unzipped["rail_vehicle"], "bundled")
    a.init()
    b.init({"solver.rtol": 1e-8, "solver.atol": 1e-10})
    q0 = 43.6e3 * ride.G / 8
    worst_z, worst_q = 0.0, 0.0
    for _ in range(100):
        a.step(0.01)
        b.step(0.01)
        worst_z = max(worst_z, abs(a.get("car.r[3]") - b.get("car.r[3]")))
        worst_q = max(worst_q, max(abs(a.get(f"contact_{w}.force") - b.get(f"contact_{w}.force")) for w in WHEELS))
    assert worst_z <= 1e-8
    assert worst_q <= 1e-3 * q0


# --------------------------------------------------------------------------------------
# The ride measures
# --------------------------------------------------------------------------------------


def test_wk_weighting_is_the_table_of_iso_2631_1():
    # ISO 2631-1:1997, Table 3, Wk (factors x 1000) at some of its one-third-octave frequencies
    table = {0.5: 418, 1.0: 482, 2.0: 531, 4.0: 967, 6.3: 1054, 10.0: 988, 20.0: 636, 50.0: 246}
    for f, factor in table.items():
        assert ride.iso2631_wk(f) == pytest.approx(factor / 1000, rel=2e-3), f


def test_ride_measures_of_a_sine():
    dt, f, b = 1e-3, 2.0, 0.5  # 2 Hz, 0.5 m/s², 10 s: a whole number of periods
    t = np.arange(10000) * dt
    a = b * np.sin(2 * math.pi * f * t)
    wz = 0.896 * ((100 * b) ** 3 * 0.325 * f**2 / f) ** 0.1
    assert ride.sperling_wz(a, dt) == pytest.approx(wz, rel=1e-12)
    assert ride.weighted_rms(a, dt) == pytest.approx(ride.iso2631_wk(f) * b / math.sqrt(2), rel=1e-12)
    assert ride.weighted_rms(a, dt, lambda f: np.ones_like(f)) == pytest.approx(b / math.sqrt(2), rel=1e-12)
