"""The model description beyond the variables' names: metadata (version, author, copyright,
license, a reproducible generation date), SI units with display units, a description on every
variable, the outputs' direct dependencies (checked against the FMU's behaviour), and the
Integer twins of the enumeration parameters for hosts that ignore Enumeration variables.
"""

import os
import subprocess
import xml.etree.ElementTree as ET
import zipfile

import fmpy
import pytest

from conftest import BINARY, ROOT, SCENES, scene_path

DEFAULT_DATE = "1980-01-01T00:00:00Z"


def description_root(fmu):
    with zipfile.ZipFile(fmu) as z:
        return ET.fromstring(z.read("modelDescription.xml"))


def export_with_env(scene, out, **env):
    result = subprocess.run(
        [str(BINARY), "export", str(scene), "-o", str(out)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env={**os.environ, **env},
    )
    return result


# --------------------------------------------------------------------------------------
# Metadata and the generation date
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", SCENES)
def test_metadata_is_complete(fmus, name):
    md = fmpy.read_model_description(str(fmus[name]))
    assert md.version == "1.0"
    assert md.author == "contact-fmu"
    assert md.copyright == "Copyright (c) contact-fmu contributors"
    assert md.license == "MIT"
    assert md.generationTool.startswith("contact-fmu ")
    assert md.generationDateAndTime == DEFAULT_DATE


@pytest.mark.parametrize("name", SCENES)
def test_packed_description_is_the_committed_one_with_its_date(fmus, name):
    with zipfile.ZipFile(fmus[name]) as z:
        packed = z.read("modelDescription.xml").decode()
    committed = (ROOT / "modelDescription" / f"{name}.xml").read_text()
    date = f' generationDateAndTime="{DEFAULT_DATE}"'
    assert date in packed
    assert packed.replace(date, "") == committed


def test_scene_metadata_keys_reach_the_description(tmp_path):
    text = scene_path("bouncing_ball").read_text().replace(
        'name = "bouncing_ball"',
        'name = "signed_ball"\nversion = "2.3.1"\nauthor = "A. Engineer <a@example.org>"\n'
        'copyright = "(c) 2025 Example & Co"\nlicense = "CC-BY-4.0"',
        1,
    )
    scene = tmp_path / "signed.toml"
    scene.write_text(text)
    result = export_with_env(scene, tmp_path / "signed.fmu")
    assert result.returncode == 0, result.stderr
    md = fmpy.read_model_description(str(tmp_path / "signed.fmu"))
    assert (md.version, md.author, md.copyright, md.license) == (
        "2.3.1",
        "A. Engineer <a@example.org>",
        "(c) 2025 Example & Co",
        "CC-BY-4.0",
    )


def test_source_date_epoch_sets_the_date_and_exports_are_reproducible(tmp_path):
    scene = scene_path("bouncing_ball")
    first, second = tmp_path / "a.fmu", tmp_path / "b.fmu"
    for out in (first, second):
        result = export_with_env(scene, out, SOURCE_DATE_EPOCH="1700000000")
        assert result.returncode == 0, result.stderr
    assert first.read_bytes() == second.read_bytes()
    assert fmpy.read_model_description(str(first)).generationDateAndTime == "2023-11-14T22:13:20Z"
    with zipfile.ZipFile(first) as z:
        assert {info.date_time for info in z.infolist()} == {(2023, 11, 14, 22, 13, 20)}


def test_without_source_date_epoch_the_date_is_fixed(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "SOURCE_DATE_EPOCH"}
    out = tmp_path / "plain.fmu"
    result = subprocess.run(
        [str(BINARY), "export", str(scene_path("two_spheres")), "-o", str(out)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env=env,
    )
    assert result.returncode == 0, result.stderr
    assert fmpy.read_model_description(str(out)).generationDateAndTime == DEFAULT_DATE
    with zipfile.ZipFile(out) as z:
        assert {info.date_time for info in z.infolist()} == {(1980, 1, 1, 0, 0, 0)}


def test_malformed_source_date_epoch_is_refused(tmp_path):
    out = tmp_path / "bad.fmu"
    result = export_with_env(scene_path("bouncing_ball"), out, SOURCE_DATE_EPOCH="yesterday")
    assert result.returncode != 0
    assert "SOURCE_DATE_EPOCH" in result.stderr and "yesterday" in result.stderr
    assert not out.exists()


# --------------------------------------------------------------------------------------
# Units and descriptions
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", SCENES)
def test_every_variable_has_a_description_and_physical_reals_have_si_units(fmus, name):
    md = fmpy.read_model_description(str(fmus[name]))
    units = {u.name: u for u in md.unitDefinitions}
    for v in md.modelVariables:
        assert v.description, f"{v.name}: no description"
        if v.type != "Real":
            continue
        # Dimensionless: quaternions, ratios, exponents, friction coefficients, tolerances; K has
        # the unit N/m^n.
        dimensionless = (
            ".q[" in v.name
            or v.name.endswith(
                (".poisson_ratio", ".restitution", ".exponent", ".stiffness", ".friction", ".static_friction")
            )
            or v.name in ("solver.rtol", "solver.atol")
        )
        if dimensionless:
            continue
        assert v.unit in units, f"{v.name}: unit {v.unit!r} not declared"
        if v.displayUnit is not None:
            assert v.displayUnit in [d.name for d in units[v.unit].displayUnits], v.name


@pytest.mark.parametrize("name", SCENES)
def test_positions_show_in_mm_and_velocities_in_km_per_h(fmus, name):
    md = fmpy.read_model_description(str(fmus[name]))
    units = {u.name: u for u in md.unitDefinitions}
    display = {d.name: d for d in units["m"].displayUnits}
    assert display["mm"].factor == 1000.0 and display["mm"].offset == 0.0
    assert units["m"].baseUnit.m == 1
    kmh = {d.name: d for d in units["m/s"].displayUnits}["km/h"]
    assert kmh.factor == 3.6
    assert (units["m/s"].baseUnit.m, units["m/s"].baseUnit.s) == (1, -1)
    by_name = {v.name: v for v in md.modelVariables}
    body = md.modelVariables[[v.name for v in md.modelVariables].index(next(n for n in by_name if n.endswith(".r[1]")))]
    stem = body.name[: -len(".r[1]")]
    for k in (1, 2, 3):
        assert (by_name[f"{stem}.r[{k}]"].unit, by_name[f"{stem}.r[{k}]"].displayUnit) == ("m", "mm")
        assert (by_name[f"{stem}.v[{k}]"].unit, by_name[f"{stem}.v[{k}]"].displayUnit) == ("m/s", "km/h")


def test_joint_and_input_units_follow_their_kind(fmus):
    md = fmpy.read_model_description(str(fmus["slider_crank"]))
    units = {v.name: (v.unit, v.displayUnit) for v in md.modelVariables}
    revolute = [n[:-2] for n, u in units.items() if n.endswith(".q") and u == ("rad", "deg")]
    prismatic = [n[:-2] for n, u in units.items() if n.endswith(".q") and u == ("m", "mm")]
    assert revolute and prismatic, units
    for j in revolute:
        assert units[f"{j}.qd"][0] == "rad/s"
    for j in prismatic:
        assert units[f"{j}.qd"][0] == "m/s"
    rail = {v.name: v for v in fmpy.read_model_description(str(fmus["rail_vehicle"])).modelVariables}
    assert rail["traction"].unit == "N"


# --------------------------------------------------------------------------------------
# Dependencies of the outputs
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", SCENES)
def test_every_output_declares_its_dependencies(fmus, name):
    root = description_root(fmus[name])
    variables = root.findall("ModelVariables/ScalarVariable")
    inputs = {str(i + 1) for i, v in enumerate(variables) if v.get("causality") == "input"}
    # a motion input's coordinate and rate (`<drive>.q`, `<drive>.qd`) move its joint at once
    drives = {v.get("name")[: -len(".qdd")] for v in variables if v.get("causality") == "input"
              and v.get("name").endswith(".qdd")}
    motion = {str(i + 1) for i, v in enumerate(variables) if v.get("causality") == "input"
              and v.get("name").rsplit(".", 1)[0] in drives and v.get("name").endswith((".q", ".qd"))}
    unknowns = root.findall("ModelStructure/Outputs/Unknown")
    assert len(unknowns) == sum(v.get("causality") == "output" for v in variables)
    for u in unknowns:
        variable = variables[int(u.get("index")) - 1]
        deps = u.get("dependencies")
        assert deps is not None, f"{variable.get('name')}: no dependencies attribute"
        if variable.get("name").endswith(".force") or ".friction_force[" in variable.get("name"):
            # A resting impulse-law contact's force (and the friction that follows it) is
            # solved with the applied forces; so is a drive's force.
            assert set(deps.split()) == inputs, variable.get("name")
        elif variable.get("name").startswith("solver."):
            assert deps == "", variable.get("name")  # the counters
        else:
            # read from the state: the coordinates and rates of the drives that move it at
            # once (none without drives; which ones: test_a_driven_joint_moves_only_what_depends_on_it)
            assert set(deps.split()) <= motion, variable.get("name")


def test_setting_an_input_changes_no_output_declared_independent(fmus, unzipped, make_instance):
    md = fmpy.read_model_description(str(fmus["rail_vehicle"]))
    dependent = {u.variable.name for u in md.outputs if u.dependencies}
    inst = make_instance(unzipped["rail_vehicle"], "deps")
    inst.init()
    for _ in range(20):
        inst.step(1e-3)
    outputs = [v for v in md.modelVariables if v.causality == "output"]
    before = {v.name: inst.get(v.name) for v in outputs}
    inst.set("traction", 5e4)
    after = {v.name: inst.get(v.name) for v in outputs}
    changed = {n for n in before if before[n] != after[n]}
    assert not changed - dependent, changed
    inst.step(1e-3)
    assert inst.get("car.v[1]") != after["car.v[1]"], "the input acts over the next step"


RESTING_BALL = """
[model]
name = "resting_ball"
stop_time = 1.0
interval = 1e-3

[[material]]
name = "steel"
youngs_modulus = 210e9
poisson_ratio = 0.3

[[body]]
name = "ball"
mass = 0.5
inertia = [2e-5, 2e-5, 2e-5]
position = [0.0, 0.0, 0.0102]

[[contact]]
name = "ball_floor"
type = "sphere_plane"
law = "impulse"
restitution = 0.3
sphere_body = "ball"
center = [0.0, 0.0, 0.0102]
radius = 0.01
sphere_material = "steel"
body = "ground"
material = "steel"
origin = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
u_axis = [1.0, 0.0, 0.0]
size = [1.0, 1.0]

[[input]]
name = "push"
type = "force"
body = "ball"
direction = [0.0, 0.0, -1.0]
"""


def test_a_resting_impulse_contact_force_follows_the_input_at_once(export_scene, make_instance):
    fmu, unzipdir = export_scene(RESTING_BALL, "resting_ball")
    md = fmpy.read_model_description(str(fmu))
    force = next(u for u in md.outputs if u.variable.name == "ball_floor.force")
    assert [d.name for d in force.dependencies] == ["push"]
    inst = make_instance(unzipdir, "resting")
    inst.init()
    for _ in range(300):
        inst.step(1e-3)
    assert inst.get("ball_floor.active"), "the ball should rest by now"
    assert inst.get("ball_floor.force") == pytest.approx(0.5 * 9.81, rel=1e-6)
    inst.set("push", 10.0)
    assert inst.get("ball_floor.force") == pytest.approx(0.5 * 9.81 + 10.0, rel=1e-6)


# --------------------------------------------------------------------------------------
# Integer twins of the enumerations
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", SCENES)
def test_every_enumeration_has_an_integer_twin(fmus, name):
    md = fmpy.read_model_description(str(fmus[name]))
    by_name = {v.name: v for v in md.modelVariables}
    enums = [v for v in md.modelVariables if v.type == "Enumeration"]
    assert enums
    for e in enums:
        twin = by_name[f"{e.name}_index"]
        assert (twin.type, twin.causality, twin.variability, twin.start) == ("Integer", "parameter", "fixed", "0")
        assert (twin.min, twin.max) == ("0", str(len(e.declaredType.items)))
        # The twins come after every variable that was there before them, so no value reference
        # moved; only the friction, inertia and contact-geometry variables, the input work and
        # the motion inputs' drive forces, added later, follow, and the contact groups' variables
        # (a group pair's law twin among them).
        groups = {v.name.rsplit(".", 1)[0] for v in md.modelVariables if v.name.endswith(".active_contacts")}
        drives = {f"{v.name[: -len('.qdd')]}.force" for v in md.modelVariables
                  if v.causality == "input" and v.name.endswith(".qdd")}
        later = [v.valueReference for v in md.modelVariables
                 if added_after_the_twins(v.name) or added_with_groups(v.name, groups) or v.name in drives]
        earlier = [v.valueReference for v in md.modelVariables if not v.name.endswith("_index") and v.valueReference not in later]
        if e.name.rsplit(".", 1)[0] in groups:
            assert max(earlier) < twin.valueReference
        else:
            assert max(earlier) < twin.valueReference < min(later)


FRICTION = (".friction", ".static_friction", ".stribeck_velocity", ".viscous_friction", ".stiction_velocity",
            ".slip_velocity")


def added_after_the_twins(name):
    """The friction, inertia and contact-geometry variables, added after the Integer twins, the
    input work and the count of contact events (added last)."""
    return (".inertia[" in name or ".size[" in name or ".friction_force[" in name
            or name.endswith((".radius", ".other_radius", ".cylinder_radius", ".length") + FRICTION)
            or name in ("energy.input_work", "solver.events"))


def added_with_groups(name, groups):
    """The contact groups' variables: per body the total contact force and torque, per group
    pair its parameters and outputs."""
    return ".contact_force[" in name or ".contact_torque[" in name or name.rsplit(".", 1)[0] in groups


def run_steps(make_instance, unzipdir, start_values, steps=200, h=1e-3):
    inst = make_instance(unzipdir, "twin")
    inst.init(start_values)
    for _ in range(steps):
        inst.step(h)
    return inst.outputs()


@pytest.mark.parametrize(
    "twin,enum,value,steps",
    # (rk4 at the ball's 1 ms step is stopped as a blow-up at its first impact, t = 0.143 s:
    # its run ends before)
    [("ball_floor.law_index", "ball_floor.law", 6, 200), ("solver.method_index", "solver.method", 3, 120)],
)
def test_an_integer_twin_sets_its_enumeration(unzipped, make_instance, twin, enum, value, steps):
    d = unzipped["bouncing_ball"]
    by_enum = run_steps(make_instance, d, {enum: value}, steps)
    assert run_steps(make_instance, d, {twin: value}, steps) == by_enum
    # The twin overrides the enumeration; 0 leaves the enumeration in charge.
    assert run_steps(make_instance, d, {enum: 1 if value != 1 else 2, twin: value}, steps) == by_enum
    assert run_steps(make_instance, d, {enum: value, twin: 0}, steps) == by_enum
    assert run_steps(make_instance, d, {}, steps) != by_enum


def test_an_integer_twin_out_of_range_is_refused(unzipped, make_instance, log):
    from fmpy.fmi1 import FMICallException

    inst = make_instance(unzipped["bouncing_ball"], "twin_range", callbacks=log.callbacks)
    inst.slave.setupExperiment(startTime=0.0)
    inst.slave.enterInitializationMode()
    inst.set("ball_floor.law_index", 7)
    with pytest.raises(FMICallException):
        inst.slave.exitInitializationMode()
    assert "ball_floor.law_index" in log.text()


def test_a_driven_joint_moves_only_what_depends_on_it(fmus, unzipped, make_instance):
    """Setting a rail's coordinate and rate (rail_vehicle_track) changes at once exactly outputs
    that declare a dependency on them: the rail's own, its wheel contact's and the energies; the
    car body and the other rails do not move until the next step."""
    md = fmpy.read_model_description(str(fmus["rail_vehicle_track"]))
    declares = {u.variable.name: {d.name for d in (u.dependencies or [])} for u in md.outputs}
    inst = make_instance(unzipped["rail_vehicle_track"], "drive deps")
    inst.init()
    inst.step(1e-3)
    names = [v.name for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
    before = {n: inst.get(n) for n in names}
    inst.set("rail_fl1.q", inst.get("lift_fl1.q") + 1e-4)
    inst.set("rail_fl1.qd", 0.01)
    changed = {n for n in names if inst.get(n) != before[n]}
    assert "railhead_fl1.r[3]" in changed and "energy.total" in changed
    for n in changed:
        assert {"rail_fl1.q", "rail_fl1.qd"} & declares[n], f"{n} changed but does not declare the rail"
    assert not declares["car.r[3]"] & {"rail_fl1.q", "rail_fl1.qd"}
    assert not declares["railhead_fr1.r[3]"] & {"rail_fl1.q", "rail_fl1.qd"}
