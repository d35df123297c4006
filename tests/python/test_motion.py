"""Motion inputs through fmpy: a base-excited oscillator (a table on a driven prismatic joint, a
mass on a spring-damper above it) stepped by a host that gives the table its coordinate, rate and
acceleration at every communication point.

- the mass's motion against the exact solution for the piecewise quadratic drive the FMU was given;
- the steady-state amplitude ratio against the transmissibility closed form;
- `shake.force` against Newton's law for the table: m_t (z̈_t + g) minus the spring-damper force on it;
- the model description declares the motion inputs and the outputs that depend on them;
- a non-finite value from the host is refused with a message naming the input, and the instance is
  usable again after a reset.
"""

import math

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.fmi1 import FMICallException

G = 9.81
M_TABLE, M_MASS, K, C, L0 = 5.0, 1.0, 1000.0, 6.0, 0.5

# the table and the mass each on a vertical prismatic joint to ground
VERTICAL_SLIDES = "".join(
    f"""
[[joint]]
name = "{body}_slide"
type = "prismatic"
parent = "ground"
child = "{body}"
axis = [0.0, 0.0, 1.0]
"""
    for body in ("table", "mass")
)

SHAKER = f"""
[model]
name = "shaker"
gravity = [0.0, 0.0, -9.81]
stop_time = 1.0
interval = 1e-3

[solver]
rtol = 1e-11
atol = 1e-13

[[body]]
name = "table"
mass = {M_TABLE}
inertia = [0.1, 0.1, 0.1]
position = [0.0, 0.0, 0.0]

[[body]]
name = "mass"
mass = {M_MASS}
inertia = [0.01, 0.01, 0.01]
position = [0.0, 0.0, {L0}]

{VERTICAL_SLIDES}
[[spring_damper]]
name = "mount"
body_a = "table"
point_a = [0.0, 0.0, 0.0]
body_b = "mass"
point_b = [0.0, 0.0, {L0}]
stiffness = {K}
damping = {C}
free_length = {L0}

[[input]]
name = "shake"
type = "joint_motion"
joint = "table_slide"
"""


def expm_damped(t):
    """e^(A t) for A = [[0, 1], [-K/m, -C/m]] (underdamped), in closed form."""
    wn = math.sqrt(K / M_MASS)
    zeta = C / (2.0 * math.sqrt(K * M_MASS))
    wd = wn * math.sqrt(1.0 - zeta * zeta)
    a = np.array([[0.0, 1.0], [-K / M_MASS, -C / M_MASS]])
    return math.exp(-zeta * wn * t) * (math.cos(wd * t) * np.eye(2) + math.sin(wd * t) / wd * (a + zeta * wn * np.eye(2)))


def exact_step(s, q, qd, qdd, h):
    """The mass's [x, ẋ] after h under the table motion y = q + qd τ + qdd τ²/2: the particular
    polynomial solution plus the homogeneous one (x: the mass's displacement from its start)."""
    a = np.array([[0.0, 1.0], [-K / M_MASS, -C / M_MASS]])
    f0 = np.array([0.0, (K * q + C * qd) / M_MASS - G])
    f1 = np.array([0.0, (K * qd + C * qdd) / M_MASS])
    f2 = np.array([0.0, K * qdd / (2.0 * M_MASS)])
    p2 = np.linalg.solve(a, -f2)
    p1 = np.linalg.solve(a, 2.0 * p2 - f1)
    p0 = np.linalg.solve(a, p1 - f0)
    return p0 + p1 * h + p2 * h * h + expm_damped(h) @ (s - p0)


def drive(t, amplitude, omega):
    return amplitude * math.sin(omega * t), amplitude * omega * math.cos(omega * t), -amplitude * omega**2 * math.sin(omega * t)


@pytest.fixture
def shaker(export_scene):
    return export_scene(SHAKER, "shaker")


def run(make_instance, unzipdir, amplitude, omega, h, steps):
    """Steps the shaker with the sampled sine. Returns per step its start (t, q, qd, qdd given,
    the drive force, mass z and v read after setting them) and its end (t, table z, mass z)."""
    inst = make_instance(unzipdir, "shaker")
    inst.init()
    starts, ends = [], []
    for k in range(steps):
        t = k * h
        q, qd, qdd = drive(t, amplitude, omega)
        inst.set("shake.q", q)
        inst.set("shake.qd", qd)
        inst.set("shake.qdd", qdd)
        starts.append((t, q, qd, qdd, inst.get("shake.force"), inst.get("mass.r[3]"), inst.get("mass.v[3]")))
        inst.step(h)
        ends.append((t + h, inst.get("table.r[3]"), inst.get("mass.r[3]")))
    return starts, ends


def test_the_mass_follows_the_exact_solution_of_the_piecewise_quadratic_drive(shaker, make_instance):
    _, unzipdir = shaker
    amplitude, omega, h, steps = 0.01, 2.0 * math.pi * 7.0, 1e-3, 500
    starts, ends = run(make_instance, unzipdir, amplitude, omega, h, steps)
    s = np.array([0.0, 0.0])
    worst, worst_force, worst_table = 0.0, 0.0, 0.0
    force_scale = M_TABLE * (amplitude * omega**2 + G)
    for (t, q, qd, qdd, force, z, v), (_, zt, z_end) in zip(starts, ends):
        # Newton's law for the table at the start of the step: m_t (ÿ + g) minus the
        # spring-damper's pull on it (its tension k e + c ė, e the extension, acts upward on it)
        x, xd = z - L0, v
        newton = M_TABLE * (qdd + G) - (K * (x - q) + C * (xd - qd))
        worst_force = max(worst_force, abs(force - newton) / force_scale)
        s = exact_step(s, q, qd, qdd, h)
        worst = max(worst, abs((z_end - L0) - s[0]) / amplitude)
        worst_table = max(worst_table, abs(zt - (q + qd * h + 0.5 * qdd * h * h)))
    print(f"mass off the exact solution by {worst:.2e} of the amplitude, drive force off Newton by {worst_force:.2e}")
    assert worst <= 1e-8
    assert worst_table <= 1e-14
    assert worst_force <= 1e-9


def test_steady_state_amplitude_ratio_is_the_transmissibility(shaker, make_instance):
    _, unzipdir = shaker
    wn = math.sqrt(K / M_MASS)
    zeta = C / (2.0 * math.sqrt(K * M_MASS))
    amplitude, h = 0.002, 1e-3
    for r in (0.6, 1.4):
        omega = r * wn
        period = 2.0 * math.pi / omega
        settle = 12.0 / (zeta * wn)
        cycles = 5
        steps = int(round((settle + cycles * period) / h))
        _, ends = run(make_instance, unzipdir, amplitude, omega, h, steps)
        t = np.array([e[0] for e in ends])
        z = np.array([e[2] for e in ends])
        window = t >= t[-1] - cycles * period
        basis = np.column_stack([np.sin(omega * t[window]), np.cos(omega * t[window]), np.ones(window.sum())])
        coef, *_ = np.linalg.lstsq(basis, z[window], rcond=None)
        measured = math.hypot(coef[0], coef[1]) / amplitude
        exact = math.sqrt((1 + (2 * zeta * r) ** 2) / ((1 - r * r) ** 2 + (2 * zeta * r) ** 2))
        print(f"r = {r}: amplitude ratio {measured:.6f}, transmissibility {exact:.6f}")
        assert abs(measured - exact) <= 1e-3 * exact


def test_motion_inputs_are_declared_and_the_outputs_depend_on_them(shaker):
    _, unzipdir = shaker
    md = read_model_description(str(unzipdir))
    by_name = {v.name: v for v in md.modelVariables}
    for name, unit in (("shake.q", "m"), ("shake.qd", "m/s"), ("shake.qdd", "m/s2")):
        v = by_name[name]
        assert (v.causality, v.variability, v.type, v.declaredType.unit if v.declaredType else v.unit) == (
            "input", "continuous", "Real", unit)
    force = by_name["shake.force"]
    assert force.causality == "output" and force.unit == "N"
    deps = {u.variable.name: {d.name for d in (u.dependencies or [])} for u in md.outputs}
    # the drive force depends on every input; the outputs of what the drive moves at once (the
    # table and the energies) on its coordinate and rate; the mass, joined by a spring only, on
    # none
    assert deps["shake.force"] == {"shake.q", "shake.qd", "shake.qdd"}
    assert deps["table.r[3]"] == {"shake.q", "shake.qd"}
    assert deps["energy.total"] == {"shake.q", "shake.qd"}
    assert deps["mass.r[3]"] == set()
    assert deps["solver.steps"] == set()


def test_a_non_finite_motion_value_is_refused_and_the_instance_recovers(shaker, make_instance, log):
    _, unzipdir = shaker
    inst = make_instance(unzipdir, "refused", callbacks=log.callbacks)
    inst.init()
    inst.step(1e-3)
    for name in ("shake.q", "shake.qd", "shake.qdd"):
        log.clear()
        with pytest.raises(FMICallException):
            inst.set(name, float("nan"))
        assert name in log.text() and "finite" in log.text(), log.text()
        inst.slave.reset()
        inst.init()
        inst.step(1e-3)
        assert math.isfinite(inst.get("mass.r[3]"))
