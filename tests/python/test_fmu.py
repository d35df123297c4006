"""The exported FMUs seen from a real FMI host (fmpy): validation, default experiments,
FMU states, instance independence, memory, resource locations, error handling and agreement
with the native `contact-fmu simulate`.
"""

import csv
import ctypes
import gc
import math
import struct
import subprocess
import sys
import urllib.parse

import fmpy
import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, fmi2LastSuccessfulTime, fmi2Terminated
from fmpy.validation import validate_fmu

from conftest import BINARY, ROOT, SCENES, copy_tree_with_space, refused_at_exit_initialization, scene_path

sys.path.insert(0, str(ROOT / "scripts"))
from bench_instance_cycles import cycle as instance_cycle  # noqa: E402
from bench_instance_cycles import rss_kib, slave_of  # noqa: E402

FMI2_WARNING = 1
FMI2_ERROR = 3
DECLARED_CATEGORIES = {
    "logEvents",
    "logStatusWarning",
    "logStatusDiscard",
    "logStatusError",
    "logStatusFatal",
    "logAll",
}


def default_experiment(md):
    de = md.defaultExperiment
    return float(de.stopTime), float(de.stepSize)


# --------------------------------------------------------------------------------------
# Validation and default experiments
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", SCENES)
def test_fmu_passes_fmpy_validation(fmus, name):
    assert validate_fmu(str(fmus[name])) == []


@pytest.mark.parametrize("name", SCENES)
def test_default_experiment_runs(fmus, name):
    md = fmpy.read_model_description(str(fmus[name]))
    stop, _ = default_experiment(md)
    result = fmpy.simulate_fmu(str(fmus[name]))  # fmpy's choices: at most 1000 communication steps
    assert result["time"][0] == 0.0
    assert result["time"][-1] == pytest.approx(stop, rel=1e-12)
    assert len(result) > 100 and np.all(np.diff(result["time"]) > 0)
    for column in result.dtype.names:
        assert np.all(np.isfinite(result[column].astype(float))), column
    # Physics sanity: total + dissipated energy stays at its initial value.
    balance = result["energy.total"] + result["energy.dissipated"]
    scale = max(abs(balance[0]), np.max(np.abs(result["energy.kinetic"])))
    assert np.max(np.abs(balance - balance[0])) < 1e-4 * scale


@pytest.mark.parametrize("law", ["hertz_ln", "impulse"])
def test_friction_set_by_a_host_makes_a_sliding_ball_roll(fmus, law):
    # The bouncing ball thrown sideways at 1 m/s with wheel-floor friction set as FMU
    # parameters: friction at the contact point keeps the angular momentum about it (gravity
    # and the normal force act through the centre), so the ball ends rolling at 5/7 of its
    # horizontal speed (docs/friction.md); exactly under the impulse law (no penetration),
    # to the lever arm R - delta under the Hertz law. The friction work is dissipated.
    laws = {"hertz_ln": 3, "impulse": 6}
    result = fmpy.simulate_fmu(
        str(fmus["bouncing_ball"]),
        stop_time=1.5,
        output_interval=1e-3,
        start_values={"ball_floor.friction": 0.3, "ball.velocity[1]": 1.0, "ball_floor.law": laws[law]},
        output=["ball.v[1]", "ball.w[2]", "ball_floor.slip_velocity", "energy.total", "energy.dissipated"],
    )
    v = result["ball.v[1]"][-1]
    tolerance = 1e-9 if law == "impulse" else 2e-3
    assert v == pytest.approx(5.0 / 7.0, rel=tolerance)
    assert result["ball_floor.slip_velocity"][-1] < 1e-3
    balance = result["energy.total"] + result["energy.dissipated"]
    assert np.max(np.abs(balance - balance[0])) < 1e-6 * abs(balance[0])


# --------------------------------------------------------------------------------------
# FMU states
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", SCENES)
def test_serialized_state_continues_bit_identically_in_another_instance(unzipped, make_instance, name):
    a = make_instance(unzipped[name], "a")
    stop, step = default_experiment(a.md)
    n = round(stop / step)
    a.init(stop_time=stop)
    for _ in range(n // 3):
        a.step(step)
    state = a.slave.getFMUstate()
    data = a.slave.serializeFMUstate(state)
    a.slave.freeFMUstate(state)
    t_saved = a.time
    expected = []
    for _ in range(n // 3):
        a.step(step)
        expected.append(a.outputs())

    b = make_instance(unzipped[name], "b")
    restored = b.slave.deSerializeFMUstate(data)
    b.slave.setFMUstate(restored)
    b.slave.freeFMUstate(restored)
    b.time = t_saved
    assert b.slave.getRealStatus(fmi2LastSuccessfulTime) == t_saved
    got = []
    for _ in range(n // 3):
        b.step(step)
        got.append(b.outputs())
    assert got == expected  # bit for bit


@pytest.mark.parametrize("target", ["terminated", "fresh"])
def test_state_restores_into_a_terminated_or_fresh_instance(unzipped, make_instance, target):
    name = SCENES[0]
    a = make_instance(unzipped[name], "a")
    stop, step = default_experiment(a.md)
    a.init(stop_time=stop)
    for _ in range(50):
        a.step(step)
    state = a.slave.getFMUstate()
    t_saved = a.time
    expected = []
    for _ in range(20):
        a.step(step)
        expected.append(a.outputs())

    if target == "terminated":
        b = a
        b.slave.terminate()
    else:
        b = make_instance(unzipped[name], "b")  # instantiated only, never initialised
    b.slave.setFMUstate(state)
    a.slave.freeFMUstate(state)  # the restored instance must not depend on the state object
    b.time = t_saved
    got = []
    for _ in range(20):
        b.step(step)
        got.append(b.outputs())
    assert got == expected


def test_corrupted_serialized_state_is_refused(unzipped, make_instance, log):
    a = make_instance(unzipped[SCENES[0]], "a", callbacks=log.callbacks)
    a.init()
    state = a.slave.getFMUstate()
    data = bytearray(a.slave.serializeFMUstate(state))
    a.slave.freeFMUstate(state)
    with pytest.raises(FMICallException):
        a.slave.deSerializeFMUstate(bytes(data[:-8]))
    assert "length" in log.text() or "bytes" in log.text()


def without_the_last_state_number(data: bytes) -> bytes:
    """A serialized state (docs/fmi.md: header, sections of tag, reserved, count and f64s, an
    FNV-1a checksum) with the last number of its state section dropped, its count and the
    checksum made to agree."""
    body = bytearray(data[:-8])
    pos, last = 24, None
    while pos < len(body):
        tag, count = struct.unpack_from("<I", body, pos)[0], struct.unpack_from("<Q", body, pos + 8)[0]
        if tag == 4:
            last = (pos, count)
        pos += 16 + 8 * count
    at, count = last
    assert at + 16 + 8 * count == len(body), "the state section is the last"
    struct.pack_into("<Q", body, at + 8, count - 1)
    del body[-8:]
    h = 0xCBF29CE484222325
    for b in body:
        h = ((h ^ b) * 0x100000001B3) & 0xFFFFFFFFFFFFFFFF
    return bytes(body) + struct.pack("<Q", h)


def test_a_state_whose_islands_do_not_fit_is_refused_and_the_saved_one_restores_after_it(unzipped, make_instance, log):
    # The pile runs as islands; its state's islands part ends the state, and its last island's
    # record (its integrator last) loses a number: the bytes parse (the count and the checksum
    # agree), fmi2SetFMUstate refuses them naming the saved islands (fmi2Error: the host may
    # then only restore a state, reset or free the instance). The undamaged state restores
    # after it, and the instance goes on as its twin that was never given either, bit for bit.
    name = "pile_of_balls"
    a = make_instance(unzipped[name], "a", callbacks=log.callbacks)
    twin = make_instance(unzipped[name], "twin")
    stop, step = default_experiment(a.md)
    for x in (a, twin):
        x.init(stop_time=stop)
    for _ in range(20):
        a.step(step)
        twin.step(step)
    state = a.slave.getFMUstate()
    data = a.slave.serializeFMUstate(state)
    a.slave.freeFMUstate(state)
    damaged = a.slave.deSerializeFMUstate(without_the_last_state_number(data))
    with pytest.raises(FMICallException):
        a.slave.setFMUstate(damaged)
    a.slave.freeFMUstate(damaged)
    assert "saved islands" in log.text()
    saved = a.slave.deSerializeFMUstate(data)
    a.slave.setFMUstate(saved)
    a.slave.freeFMUstate(saved)
    got, expected = side_by_side(a, twin, step, 20)
    assert got == expected


def side_by_side(a, b, step, n):
    """Steps instances `a` and `b` `n` times by turns; each one's outputs after every step."""
    got_a, got_b = [], []
    for _ in range(n):
        a.step(step)
        b.step(step)
        got_a.append(a.outputs())
        got_b.append(b.outputs())
    return got_a, got_b


# --------------------------------------------------------------------------------------
# Instances
# --------------------------------------------------------------------------------------


def test_two_instances_in_one_process_are_independent(unzipped, make_instance):
    name = "bouncing_ball" if "bouncing_ball" in SCENES else SCENES[0]
    solo = make_instance(unzipped[name], "solo")
    _, step = default_experiment(solo.md)
    solo.init()
    reference = []
    for _ in range(200):
        solo.step(step)
        reference.append(solo.outputs())
    solo.free()

    a = make_instance(unzipped[name], "a")
    b = make_instance(unzipped[name], "b")
    mass = next(v for v in a.vars if v.endswith(".mass"))
    a.init()
    b.init(start_values={mass: 2.0 * float(a.vars[mass].start)})
    got_a, got_b = side_by_side(a, b, step, 200)
    assert got_a == reference  # b's calls, interleaved, left a untouched
    assert got_b != reference  # and b really has its own parameters


def test_thousand_instantiate_free_cycles_do_not_grow_memory(unzipped):
    name = SCENES[0]
    md = fmpy.read_model_description(str(unzipped[name]))
    _, step = default_experiment(md)

    def cycle():
        # fmpy's own pattern: load the library, instantiate, run a little, free, unload.
        slave = slave_of(md, unzipped[name])
        instance_cycle(slave, step)
        slave.freeLibrary()

    for _ in range(100):
        cycle()
    gc.collect()
    before = rss_kib()
    for _ in range(1000):
        cycle()
    gc.collect()
    growth = rss_kib() - before
    assert growth < 5 * 1024, f"resident memory grew by {growth} KiB over 1000 cycles"


# --------------------------------------------------------------------------------------
# Resource locations
# --------------------------------------------------------------------------------------


def test_resource_path_with_a_space(unzipped, make_instance, tmp_path):
    name = SCENES[0]
    spaced = copy_tree_with_space(unzipped[name], tmp_path)
    plain = make_instance(unzipped[name], "plain")
    inst = make_instance(spaced, "spaced")
    _, step = default_experiment(inst.md)
    plain.init()
    inst.init()
    for _ in range(10):
        plain.step(step)
        inst.step(step)
    assert inst.outputs() == plain.outputs()


@pytest.mark.parametrize("form", ["file:/", "file:///", "file:////", "file://localhost/", "unencoded"])
def test_every_resource_uri_form_is_accepted(unzipped, tmp_path, log, form):
    name = SCENES[0]
    spaced = copy_tree_with_space(unzipped[name], tmp_path)
    resources = str(spaced / "resources")
    quoted = urllib.parse.quote(resources.lstrip("/"))
    uri = {
        "file:/": "file:/" + quoted,
        "file:///": "file:///" + quoted,
        "file:////": "file:////" + quoted,
        "file://localhost/": "file://localhost/" + quoted,
        "unencoded": "file:///" + resources.lstrip("/"),
    }[form]
    md = fmpy.read_model_description(str(spaced))
    slave = FMU2Slave(guid=md.guid, unzipDirectory=str(spaced), modelIdentifier=md.coSimulation.modelIdentifier)
    try:
        component = slave.fmi2Instantiate(b"uri", 1, md.guid.encode(), uri.encode(), ctypes.byref(log.callbacks), 0, 0)
        assert component, log.text()
        slave.fmi2FreeInstance(component)
    finally:
        slave.freeLibrary()


# --------------------------------------------------------------------------------------
# Logging and errors
# --------------------------------------------------------------------------------------


def test_wrong_guid_returns_null_and_logs(unzipped, make_instance, log):
    inst = make_instance(
        unzipped[SCENES[0]], "wrong", guid="{00000000-%s%n%d-0000-0000-000000000000}", instantiate=False
    )
    with pytest.raises(Exception, match="Failed to instantiate"):
        inst.slave.instantiate(callbacks=log.callbacks)
    assert not inst.slave.component
    text = log.text()
    assert "GUID" in text
    # The host's GUID is quoted verbatim: '%' in a message is never taken as a format.
    assert "%s%n%d" in text


@pytest.mark.parametrize("name", ["", "   ", "\t"])
def test_empty_instance_name_returns_null_and_logs(unzipped, make_instance, log, name):
    """The name must hold "at least one character that is no white space" (white space
    alone was accepted)."""
    inst = make_instance(unzipped[SCENES[0]], name, instantiate=False)
    with pytest.raises(Exception, match="Failed to instantiate"):
        inst.slave.instantiate(callbacks=log.callbacks)
    assert "instance name" in log.text()


def test_logger_gets_a_plain_format_a_declared_category_and_the_environment(unzipped, make_instance):
    """A raw (non-proxied) logger sees exactly what the library passes."""
    seen = []

    def raw_logger(env, instance_name, status, category, message):
        seen.append((env, instance_name, status, category, message))

    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(raw_logger)
    callbacks.componentEnvironment = ctypes.c_void_p(0x5EED)
    inst = make_instance(unzipped[SCENES[0]], "raw", callbacks=callbacks)
    inst.slave.setDebugLogging(True, [])
    with pytest.raises(FMICallException):
        inst.step(0.001)  # before initialisation: illegal
    assert seen
    for env, instance_name, status, category, message in seen:
        assert env == 0x5EED
        assert instance_name == b"raw"
        assert message == b"%s"
        assert category is not None and category.decode() in DECLARED_CATEGORIES
    assert any(s == FMI2_ERROR and c == b"logStatusError" for _, _, s, c, _ in seen)


def test_unknown_log_category_is_an_error(unzipped, make_instance, log):
    inst = make_instance(unzipped[SCENES[0]], "cat", callbacks=log.callbacks)
    inst.slave.setDebugLogging(True, ["logEvents", "logAll"])
    with pytest.raises(FMICallException):
        inst.slave.setDebugLogging(True, ["noSuchCategory"])
    assert "noSuchCategory" in log.text()


def test_switching_categories_on_logs_the_events_only_when_named(unzipped, make_instance, log):
    """FMI 2.0: with loggingOn and categories, "only debug messages according to the
    categories argument shall be printed" (naming logStatusWarning let the events through)."""
    inst = make_instance(unzipped[SCENES[0]], "categories", callbacks=log.callbacks)
    inst.slave.setDebugLogging(True, ["logStatusWarning"])
    inst.slave.setupExperiment(startTime=0.0)
    inst.slave.enterInitializationMode()
    inst.slave.exitInitializationMode()
    inst.slave.reset()
    assert not [m for m in log.messages if m[1] == "logEvents"], log.messages
    inst.slave.setDebugLogging(True, ["logEvents"])
    inst.slave.reset()
    assert [m for m in log.messages if m[1] == "logEvents"], log.messages
    # a later call naming another category leaves the events on (each call switches the
    # categories it names)
    log.clear()
    inst.slave.setDebugLogging(True, ["logStatusDiscard"])
    inst.slave.reset()
    assert [m for m in log.messages if m[1] == "logEvents"], log.messages
    # errors stay logged (they are switched off only by name)
    with pytest.raises(FMICallException):
        inst.step(0.001)  # before initialisation: illegal
    assert any(m[1] == "logStatusError" for m in log.messages)


def bouncing_ball_with_stiffness():
    text = scene_path("bouncing_ball").read_text()
    assert 'law = "hertz_ln"' in text
    return text.replace('law = "hertz_ln"', 'law = "hertz_ln"\nstiffness = 1.0e10', 1)


OUT_OF_RANGE = [
    ("ball.mass", -1.0),
    ("ball.mass", 0.0),
    ("steel.poisson_ratio", 0.5),
    ("steel.youngs_modulus", -2e11),
    ("ball_floor.restitution", 1.5),
    ("ball_floor.stiffness", -1.0),
    ("solver.rtol", 0.0),
    ("solver.rtol", -1e-6),
    ("solver.method", 99),
    ("ball.inertia[2]", -1e-6),
    ("ball_floor.radius", 0.0),
    ("ball_floor.size[1]", -1.0),
    # a band of admitted penetrations too thin to be seen: the ball fell through the floor
    ("ball_floor.max_penetration", 1e-300),
]


@pytest.mark.parametrize("variable,value", OUT_OF_RANGE)
def test_out_of_range_parameter_is_refused_at_exit_initialization(export_scene, make_instance, log, variable, value):
    _, unzipdir = export_scene(bouncing_ball_with_stiffness(), "stiff_ball")
    inst = make_instance(unzipdir, "range", callbacks=log.callbacks)
    assert refused_at_exit_initialization(inst, variable, value).status == FMI2_ERROR
    assert variable in log.text()
    # The instance is in the error state, and fmi2Reset makes it usable again.
    with pytest.raises(FMICallException):
        inst.step(1e-3)
    inst.slave.reset()
    inst.init()
    inst.step(1e-3)


def test_do_step_before_initialization_is_an_error_not_a_crash(unzipped, make_instance, log):
    inst = make_instance(unzipped[SCENES[0]], "early", callbacks=log.callbacks)
    with pytest.raises(FMICallException) as raised:
        inst.step(1e-3)
    assert raised.value.status == FMI2_ERROR
    assert "illegal call sequence" in log.text()


def test_setting_a_fixed_parameter_after_initialization_is_an_error(unzipped, make_instance, log):
    inst = make_instance(unzipped[SCENES[0]], "late", callbacks=log.callbacks)
    inst.init()
    mass = next(v for v in inst.vars if v.endswith(".mass"))
    with pytest.raises(FMICallException) as raised:
        inst.set(mass, 1.0)
    assert raised.value.status == FMI2_ERROR
    assert mass in log.text()


# --------------------------------------------------------------------------------------
# Geometry and inertia parameters, tunable contact-law constants, the energy warning
# --------------------------------------------------------------------------------------

G = 9.81


def test_geometry_and_inertia_parameters_equal_the_scene_edited_by_hand(fmus, export_scene):
    text = scene_path("bouncing_ball").read_text()
    changes = {
        "ball.mass": ("mass = 0.0329", "mass = 0.05"),
        "ball.inertia[1]": ("inertia = [1.316e-6, 1.316e-6, 1.316e-6]", "inertia = [2e-6, 2.5e-6, 3e-6]"),
        "ball.inertia[2]": None,
        "ball.inertia[3]": None,
        "ball_floor.radius": ("radius = 0.01", "radius = 0.012"),
        "ball_floor.size[1]": ("size = [1.0, 1.0]", "size = [0.5, 2.0]"),
        "ball_floor.size[2]": None,
    }
    edited = text
    for old, new in (c for c in changes.values() if c):
        assert old in edited
        edited = edited.replace(old, new, 1)
    start_values = {
        "ball.mass": 0.05,
        "ball.inertia[1]": 2e-6,
        "ball.inertia[2]": 2.5e-6,
        "ball.inertia[3]": 3e-6,
        "ball_floor.radius": 0.012,
        "ball_floor.size[1]": 0.5,
        "ball_floor.size[2]": 2.0,
    }
    assert set(start_values) == set(changes)
    by_hand, _ = export_scene(edited, "ball_by_hand")
    md = fmpy.read_model_description(str(fmus["bouncing_ball"]))
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    kwargs = dict(stop_time=0.5, output_interval=1e-3, output=outputs)
    with_parameters = fmpy.simulate_fmu(str(fmus["bouncing_ball"]), start_values=start_values, **kwargs)
    expected = fmpy.simulate_fmu(str(by_hand), **kwargs)
    unchanged = fmpy.simulate_fmu(str(fmus["bouncing_ball"]), **kwargs)
    for column in ["time", *outputs]:
        assert np.array_equal(with_parameters[column], expected[column]), column
    assert not np.array_equal(with_parameters["ball.r[3]"], unchanged["ball.r[3]"])


def flight_speed(inst, radius=0.01):
    """The ball's speed at the plate from its state in flight, sqrt(v^2 + 2 g (z - R)):
    constant between impacts, the rebound speed of the last impact."""
    z, v = inst.get("ball.r[3]"), inst.get("ball.v[3]")
    return math.sqrt(v * v + 2 * G * (z - radius))


def step_until(inst, t, h=1e-3):
    while inst.time < t - 1e-12:
        inst.step(h)


def test_restitution_set_between_steps_gives_each_bounce_its_closed_form(unzipped, make_instance):
    # impulse law (Newton's restitution, exact); the ball drops 0.1 m: v0 = sqrt(2 g h)
    inst = make_instance(unzipped["bouncing_ball"], "tunable")
    assert inst.vars["ball_floor.restitution"].variability == "tunable"
    inst.init(start_values={"ball_floor.law": 6})
    v0 = math.sqrt(2 * G * 0.1)
    expected = [v0]
    for e in [0.8, 0.5, 0.3, 0.9]:
        expected.append(expected[-1] * e)
    # the changes at 0.2, 0.4 and 0.5 s each fall between two impacts
    for t, e in [(0.2, 0.5), (0.4, 0.3), (0.5, 0.9), (0.545, None)]:
        step_until(inst, t)
        impacts = inst.get("ball_floor.impacts")
        assert flight_speed(inst) == pytest.approx(expected[impacts], rel=0, abs=1e-9 * v0), t
        if e is not None:
            inst.set("ball_floor.restitution", e)
            assert inst.get("ball_floor.restitution") == e
    assert inst.get("ball_floor.impacts") == 4
    # each impact stopped the integration once: the FMU's event counter says so
    assert inst.get("solver.events") == 4


def test_a_tunable_change_equals_the_same_change_after_a_restore_and_a_state_keeps_its_values(
    unzipped, make_instance
):
    a = make_instance(unzipped["bouncing_ball"], "a")
    a.init()
    step_until(a, 0.2)
    t_saved = a.time  # the sum of the steps, as the FMU's own time
    state = a.slave.getFMUstate()
    saved = a.slave.serializeFMUstate(state)
    a.slave.freeFMUstate(state)
    a.set("ball_floor.restitution", 0.3)
    changed = []
    for _ in range(300):
        a.step(1e-3)
        changed.append(a.outputs())
    # another instance, restored from the state saved before the change, changed the same way
    b = make_instance(unzipped["bouncing_ball"], "b")
    b.slave.setFMUstate(b.slave.deSerializeFMUstate(saved))
    b.time = t_saved
    assert b.get("ball_floor.restitution") == 0.8
    b.set("ball_floor.restitution", 0.3)
    restored = []
    for _ in range(300):
        b.step(1e-3)
        restored.append(b.outputs())
    assert changed == restored
    # restoring the state saved before the change restores the old value and the old future
    a.slave.setFMUstate(a.slave.deSerializeFMUstate(saved))
    a.time = t_saved
    assert a.get("ball_floor.restitution") == 0.8
    untouched = []
    for _ in range(300):
        a.step(1e-3)
        untouched.append(a.outputs())
    assert untouched != changed
    fresh = make_instance(unzipped["bouncing_ball"], "fresh")
    fresh.init()
    step_until(fresh, 0.5)
    assert fresh.outputs() == untouched[-1]


def test_a_bad_tunable_value_and_a_fixed_parameter_are_refused_after_initialization(unzipped, make_instance, log):
    inst = make_instance(unzipped["bouncing_ball"], "refused", callbacks=log.callbacks)
    inst.init()
    inst.step(1e-3)
    with pytest.raises(FMICallException) as raised:
        inst.set("ball_floor.restitution", 1.5)
    assert raised.value.status == FMI2_ERROR
    assert "ball_floor.restitution = 1.5 is out of its allowed range [0, 1]" in log.text()
    inst.slave.reset()
    inst.init()
    with pytest.raises(FMICallException):
        inst.set("ball_floor.radius", 0.02)
    assert "ball_floor.radius is a fixed parameter" in log.text()


def test_energy_drift_is_logged_once_as_a_warning(export_scene, unzipped, make_instance, log):
    # rk4 at 30 us through a steel contact of ~40 us gains energy (at 0.1 ms it gains twenty
    # times its energy at the first impact and is stopped as a blow-up: test_blow_up.py)
    text = scene_path("bouncing_ball").read_text().replace("[solver]\n", '[solver]\nmethod = "rk4"\nmax_step = 3e-5\n', 1)
    assert 'method = "rk4"' in text
    _, coarse = export_scene(text, "coarse_ball")
    inst = make_instance(coarse, "coarse", callbacks=log.callbacks)
    inst.init()
    for _ in range(1000):
        inst.step(1e-3)
    warnings = [(s, c, m) for s, c, m in log.messages if "energy balance" in m]
    assert len(warnings) == 1, warnings
    status, category, message = warnings[0]
    assert (status, category) == (FMI2_WARNING, "logStatusWarning")
    assert "more than 1 %" in message and message.startswith("fmi2DoStep: at t = 0.1")
    log.clear()
    default = make_instance(unzipped["bouncing_ball"], "default", callbacks=log.callbacks)
    default.init()
    for _ in range(1000):
        default.step(1e-3)
    assert log.messages == []


def test_type_and_reference_errors(unzipped, make_instance, log):
    inst = make_instance(unzipped[SCENES[0]], "types", callbacks=log.callbacks)
    inst.init()
    boolean = next(v.valueReference for v in inst.md.modelVariables if v.type == "Boolean")
    with pytest.raises(FMICallException):
        inst.slave.getReal([boolean])
    assert "Boolean" in log.text()
    inst.slave.reset()
    inst.init()
    with pytest.raises(FMICallException):
        inst.slave.getReal([100000])
    assert "unknown value reference" in log.text()


def test_bad_communication_points_are_refused(unzipped, make_instance, log):
    inst = make_instance(unzipped[SCENES[0]], "steps", callbacks=log.callbacks)
    inst.init()
    with pytest.raises(FMICallException):
        inst.slave.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.0)
    inst.slave.reset()
    inst.init()
    with pytest.raises(FMICallException):
        inst.slave.doStep(currentCommunicationPoint=0.5, communicationStepSize=1e-3)
    assert "current time" in log.text()


def test_status_queries(unzipped, make_instance):
    inst = make_instance(unzipped[SCENES[0]], "status")
    _, step = default_experiment(inst.md)
    inst.init()
    for _ in range(3):
        inst.step(step)
    assert inst.slave.getRealStatus(fmi2LastSuccessfulTime) == pytest.approx(3 * step, rel=1e-12)
    assert not inst.slave.getBooleanStatus(fmi2Terminated)
    inst.slave.terminate()
    assert inst.slave.getBooleanStatus(fmi2Terminated)


def test_unsupported_functions_return_error(unzipped, make_instance, log):
    inst = make_instance(unzipped[SCENES[0]], "unsupported", callbacks=log.callbacks)
    inst.init()
    output = next(v.valueReference for v in inst.md.modelVariables if v.causality == "output" and v.type == "Real")
    param = next(v.valueReference for v in inst.md.modelVariables if v.causality == "parameter" and v.type == "Real")
    with pytest.raises(FMICallException):
        inst.slave.getDirectionalDerivative([output], [param], [1.0])
    assert "not supported" in log.text()
    with pytest.raises(FMICallException) as raised:
        inst.slave.fmi2CancelStep(inst.slave.component)
    assert raised.value.status == FMI2_ERROR


# --------------------------------------------------------------------------------------
# Agreement with the native simulator
# --------------------------------------------------------------------------------------


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, data = rows[0], rows[1:]
    values = {}
    for k, name in enumerate(header):
        column = []
        for row in data:
            text = row[k]
            column.append(1.0 if text == "true" else 0.0 if text == "false" else float(text))
        values[name] = np.array(column)
    return values


@pytest.mark.parametrize("name", SCENES)
@pytest.mark.parametrize("changed", [False, True])
def test_fmu_results_equal_native_simulate(fmus, tmp_path, name, changed):
    md = fmpy.read_model_description(str(fmus[name]))
    mass = next(v.name for v in md.modelVariables if v.name.endswith(".mass"))
    start_values, settings = {}, []
    if changed:
        new_mass = 1.5 * float(next(v.start for v in md.modelVariables if v.name == mass))
        start_values[mass] = new_mass
        settings = ["--set", f"{mass}={new_mass!r}"]
    out = tmp_path / "native.csv"
    subprocess.run(
        [str(BINARY), "simulate", str(scene_path(name)), "--csv", str(out), "--quiet", *settings],
        cwd=ROOT,
        check=True,
    )
    native = read_csv(out)
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    assert list(native) == ["time", *outputs]
    _, step = default_experiment(md)
    result = fmpy.simulate_fmu(str(fmus[name]), output=outputs, start_values=start_values, output_interval=step)
    assert len(result) == len(native["time"])
    np.testing.assert_allclose(result["time"], native["time"], rtol=0, atol=1e-12 * float(native["time"][-1]))
    for column in outputs:
        fmu_values = result[column].astype(float)
        same_nan = np.isnan(fmu_values) & np.isnan(native[column])
        assert np.array_equal(np.isnan(fmu_values), np.isnan(native[column])), f"{column}: NaN in one of them only"
        scale = max(1.0, float(np.max(np.abs(native[column][~same_nan]), initial=0.0)))
        worst = float(np.max(np.abs(fmu_values - native[column])[~same_nan], initial=0.0))
        assert worst <= 1e-12 * scale, f"{column}: FMU and native differ by {worst}"
    if changed:
        # The parameter really reached the model: the heavier body moves differently.
        baseline = fmpy.simulate_fmu(str(fmus[name]), output=outputs, output_interval=step)
        assert any(not np.array_equal(baseline[c], result[c]) for c in outputs)


@pytest.mark.parametrize("name", SCENES)
def test_initial_unknowns_are_available_in_initialization_mode(unzipped, make_instance, name):
    inst = make_instance(unzipped[name], "initial")
    inst.slave.setupExperiment(startTime=0.0)
    inst.slave.enterInitializationMode()
    unknowns = [u.variable for u in inst.md.initialUnknowns]
    reals = [v.valueReference for v in unknowns if v.type == "Real"]
    during = inst.slave.getReal(reals)
    inst.slave.exitInitializationMode()
    after = inst.slave.getReal(reals)
    assert [float(x).hex() for x in during] == [float(x).hex() for x in after]
    calculated = [v for v in unknowns if v.causality == "calculatedParameter"]
    for v in calculated:
        value = inst.slave.getReal([v.valueReference])[0]
        assert math.isfinite(value) and value > 0, f"{v.name} = {value}"


def test_failed_step_is_an_error_with_the_last_successful_time(unzipped, make_instance, log):
    name = "bouncing_ball"
    inst = make_instance(unzipped[name], "fail", callbacks=log.callbacks)
    _, step = default_experiment(inst.md)
    inst.init(start_values={"ball_floor.max_penetration": 1e-9})
    saved = None
    with pytest.raises(FMICallException) as raised:
        for k in range(1000):
            if k == 100:
                saved = inst.slave.getFMUstate()
            inst.step(step)
    assert raised.value.status == FMI2_ERROR
    assert "max_penetration" in log.text()
    last = inst.slave.getRealStatus(fmi2LastSuccessfulTime)
    assert inst.time <= last < inst.time + step  # inside the step that failed
    # The outputs at the failure stay readable, and an earlier state can be restored.
    assert math.isfinite(inst.slave.getReal([inst.vr("ball.r[3]")])[0])
    inst.slave.setFMUstate(saved)
    inst.slave.freeFMUstate(saved)
    inst.time = 100 * step
    inst.step(step)


def test_a_host_tolerance_that_replaces_solver_rtol_is_logged(unzipped, make_instance, log):
    a = make_instance(unzipped[SCENES[0]], "a", callbacks=log.callbacks)
    a.slave.setDebugLogging(True, [])
    a.slave.setupExperiment(tolerance=1e-4, startTime=0.0)
    assert "replaces solver.rtol" in log.text()
    a.slave.enterInitializationMode()
    a.slave.exitInitializationMode()
    assert a.slave.getReal([a.vr("solver.rtol")]) == [1e-4]
