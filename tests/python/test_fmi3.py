"""The FMI 3.0 FMUs (`contact-fmu export --fmi-version 3`, target/fmu3/<name>.fmu): valid for
fmpy, the same numbers as the FMI 2.0 FMUs bit for bit, a step that returns early at contact
events (the bouncing ball's impacts at their closed-form times), serialized states that
round-trip, and refusals: states of the other FMI version, illegal call sequences, bad
arguments, FMI 2.0 handles (docs/fmi3.md)."""

import ctypes
import math
import zipfile

import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave, fmi3Boolean, fmi3Float64
from fmpy.validation import validate_fmu

from conftest import SCENES

G = 9.81


class Host3:
    """One FMI 3.0 instance through fmpy's FMU3Slave, with its log collected."""

    def __init__(self, fmu, tmp_path, name="fmi3", early_return=False, instantiate=True, **kwargs):
        self.unzipped = tmp_path / f"unzipped_{name}"
        if not self.unzipped.exists():
            with zipfile.ZipFile(fmu) as z:
                z.extractall(self.unzipped)
        self.md = read_model_description(str(self.unzipped))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.messages = []
        self.slave = FMU3Slave(
            guid=kwargs.pop("token", None) or self.md.guid,
            unzipDirectory=str(self.unzipped),
            modelIdentifier=self.md.coSimulation.modelIdentifier,
            instanceName=name,
        )
        if instantiate:
            self.slave.instantiate(earlyReturnAllowed=early_return, logMessage=self.log, **kwargs)

    def log(self, env, status, category, message):
        self.messages.append((status, category.decode(), message.decode()))

    def text(self):
        return "\n".join(m[2] for m in self.messages)

    def init(self, stop_time=None, **values):
        self.slave.enterInitializationMode(startTime=0.0, stopTime=stop_time)
        for name, value in values.items():
            v = next(v for v in self.md.modelVariables if v.name == name)
            if v.type == "Enumeration":
                self.slave.setInt64([v.valueReference], [int(value)])
            elif v.type == "Int32":
                self.slave.setInt32([v.valueReference], [int(value)])
            else:
                self.slave.setFloat64([v.valueReference], [value])
        self.slave.exitInitializationMode()

    def outputs(self):
        """Every Float64 output as `float.hex` (a list comparison compares bits)."""
        vrs = [v.valueReference for v in self.md.modelVariables if v.causality == "output" and v.type == "Float64"]
        return [x.hex() for x in self.slave.getFloat64(vrs)]

    def free(self):
        self.slave.freeInstance()


@pytest.mark.parametrize("name", SCENES)
def test_valid_and_the_same_numbers_as_the_fmi2_fmu(fmus, fmus3, name):
    fmu2, fmu3 = fmus[name], fmus3[name]
    assert validate_fmu(str(fmu3)) == []
    md2, md3 = read_model_description(str(fmu2)), read_model_description(str(fmu3))
    assert md3.fmiVersion == "3.0" and md3.guid == md2.guid
    assert md3.coSimulation.mightReturnEarlyFromDoStep
    # the same variables at the same value references, and FMI 3.0's time after them
    v2 = [(v.name, v.valueReference, v.causality) for v in md2.modelVariables]
    v3 = [(v.name, v.valueReference, v.causality) for v in md3.modelVariables if v.name != "time"]
    assert v3 == v2
    time = next(v for v in md3.modelVariables if v.name == "time")
    assert (time.causality, time.valueReference) == ("independent", len(v2))
    types = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean", "Enumeration": "Enumeration"}
    assert [types[v.type] for v in md2.modelVariables] == [v.type for v in md3.modelVariables if v.name != "time"]
    names = zipfile.ZipFile(fmu3).namelist()
    ident = md3.coSimulation.modelIdentifier
    assert f"binaries/x86_64-linux/{ident}.so" in names and f"binaries/x86_64-windows/{ident}.dll" in names
    # the default experiment, every output at every communication point, bit for bit
    r2, r3 = simulate_fmu(str(fmu2)), simulate_fmu(str(fmu3))
    assert r2.dtype.names == r3.dtype.names and len(r2) == len(r3) > 10
    differing = [k for k in r2.dtype.names if r2[k].tobytes() != r3[k].tobytes()]
    assert differing == []


def impact_times(height, e, stop):
    """The closed-form impact times of a ball dropped from rest, `height` above the floor,
    bouncing with restitution `e` (free flight between impacts)."""
    v = math.sqrt(2 * G * height)
    t, times = v / G, []
    while t < stop:
        times.append(t)
        v *= e
        t += 2 * v / G
    return times


def run_on_grid(host, stop, h, read=()):
    """Steps to every multiple of `h` up to `stop`; a step that returns early is continued to
    its communication point. Returns (outputs at the grid points, [(time, values of `read`)]
    at the early returns)."""
    grid, returns = [], []
    t, n, last_n = 0.0, 0, round(stop / h)
    while n < last_n:
        target = stop if n + 1 == last_n else (n + 1) * h
        _, terminate, early, last = host.slave.doStep(t, target - t)
        assert not terminate
        if early:
            assert t < last < target
            returns.append((last, host.slave.getFloat64([host.vr[k] for k in read])))
            t = last
        else:
            assert abs(last - target) <= 1e-15
            t, n = target, n + 1
            grid.append(host.outputs())
    return grid, returns


def test_early_return_at_every_impact_of_the_bouncing_ball(fmus3, tmp_path):
    """Impulse law, e = 0.8: each impact ends a step at its closed-form time; the grid's
    outputs equal those of the run without early returns, bit for bit."""
    stop, h, e = 1.0, 1e-3, 0.8
    runs = {}
    for early in (True, False):
        host = Host3(fmus3["bouncing_ball"], tmp_path, early_return=early)
        host.init(stop_time=stop, **{"ball_floor.law": 6, "ball_floor.restitution": e})
        runs[early] = run_on_grid(host, stop, h, read=["ball.r[3]", "ball.v[3]"])
        host.free()
    (grid, returns), (plain, none) = runs[True], runs[False]
    assert none == [] and grid == plain
    exact = impact_times(0.1, e, stop)
    assert len(exact) == 7 and len(returns) == len(exact)
    for k, ((t, (z, rate)), t_exact) in enumerate(zip(returns, exact)):
        # located to the event tolerance (1e-13 relative), twice for the closed form's rounding
        assert abs(t - t_exact) <= 2e-13 * max(t_exact, 1e-3), (k, t, t_exact)
        # on the floor, and already bouncing back at e times the impact speed
        v = math.sqrt(2 * G * 0.1) * e ** (k + 1)
        assert abs(z - 0.01) < 1e-11 and rate == pytest.approx(v, rel=1e-9), (k, z, rate)


@pytest.mark.parametrize("name, stop", [("bouncing_ball", 0.5), ("two_spheres", 0.01), ("pile_of_balls", 0.1)])
def test_early_returns_leave_the_trajectory_unchanged(fmus3, tmp_path, name, stop):
    """The bundled continuous laws (touch and separation) and the pile of balls (independent
    islands, the others taken back to the island's event): the same outputs at every
    communication point with and without early returns."""
    md = read_model_description(str(fmus3[name]))
    h = float(md.defaultExperiment.stepSize)
    runs = {}
    for early in (True, False):
        host = Host3(fmus3[name], tmp_path, name=f"{name}{early}", early_return=early)
        host.init(stop_time=stop)
        runs[early] = run_on_grid(host, stop, h)
        host.free()
    (grid, returns), (plain, none) = runs[True], runs[False]
    assert len(returns) > 0 and none == []
    assert grid == plain


def test_serialized_states_round_trip_bit_for_bit(fmus3, tmp_path):
    a = Host3(fmus3["bouncing_ball"], tmp_path, name="a")
    a.init()
    for k in range(300):
        a.slave.doStep(k * 1e-3, 1e-3)
    state = a.slave.getFMUState()
    data = a.slave.serializeFMUState(state)
    b = Host3(fmus3["bouncing_ball"], tmp_path, name="b")
    restored = b.slave.deserializeFMUState(data)
    b.slave.setFMUState(restored)
    assert b.slave.serializeFMUState(restored) == data
    assert b.outputs() == a.outputs()
    for k in range(300, 600):
        a.slave.doStep(k * 1e-3, 1e-3)
        b.slave.doStep(k * 1e-3, 1e-3)
    assert b.outputs() == a.outputs()
    a.slave.freeFMUState(state)
    b.slave.freeFMUState(restored)
    a.free()
    b.free()


def test_states_of_the_other_fmi_version_are_refused(fmus, fmus3, tmp_path, unzipped):
    three = Host3(fmus3["bouncing_ball"], tmp_path)
    three.init()
    three.slave.doStep(0.0, 1e-3)
    data3 = three.slave.serializeFMUState(three.slave.getFMUState())
    md2 = read_model_description(str(unzipped["bouncing_ball"]))
    two = FMU2Slave(guid=md2.guid, unzipDirectory=str(unzipped["bouncing_ball"]),
                    modelIdentifier=md2.coSimulation.modelIdentifier, instanceName="two")
    two.instantiate()
    two.setupExperiment(startTime=0.0)
    two.enterInitializationMode()
    two.exitInitializationMode()
    data2 = two.serializeFMUstate(two.getFMUstate())
    assert data2[:8] == data3[:8] == b"CFMUSTAT" and len(data3) == len(data2) + 8
    with pytest.raises(FMICallException):
        three.slave.deserializeFMUState(data2)
    assert "saved by an FMI 2.0 instance; an FMI 3.0 instance does not restore it" in three.text()
    with pytest.raises(FMICallException):
        two.deSerializeFMUstate(data3)
    two.freeInstance()
    three.free()


def test_illegal_call_sequences_and_bad_arguments_are_refused(fmus3, fmus, unzipped, tmp_path):
    fmu = fmus3["bouncing_ball"]
    # a wrong token, event mode, intermediate variables: no instance
    for kwargs in ({"token": "{00000000-0000-0000-0000-000000000000}"}, {"eventModeUsed": True},
                   {"requiredIntermediateVariables": [1]}):
        token = kwargs.pop("token", None)
        host = Host3(fmu, tmp_path, name="refused", instantiate=False, token=token)
        with pytest.raises(Exception, match="Failed to instantiate"):
            host.slave.instantiate(logMessage=host.log, **kwargs)
        assert host.messages and host.messages[-1][0] == 3, kwargs
    host = Host3(fmu, tmp_path)
    f = host.slave
    raw = f._functions  # the C functions themselves (fmpy's methods raise on an error status)
    # a step before initialisation, Step Mode entered (it is entered by exiting initialisation)
    with pytest.raises(FMICallException):
        f.doStep(0.0, 1e-3)
    assert "illegal call sequence: fmi3DoStep is not allowed in the instantiated state" in host.text()
    f.reset()
    host.init()
    with pytest.raises(FMICallException):
        f.enterStepMode()
    assert "fmi3EnterStepMode is not allowed in the step mode state" in host.text()
    f.reset()
    host.init()
    # nValues differing from the value references, an output set, a Float64 read as Int32
    vr = host.vr["ball.r[3]"]
    values = (fmi3Float64 * 2)()
    vrs = (ctypes.c_uint32 * 1)(vr)
    assert raw["fmi3GetFloat64"](f.component, vrs, 1, values, 2) == 3
    f.reset()
    host.init()
    with pytest.raises(FMICallException):
        f.setFloat64([vr], [1.0])
    assert "ball.r[3] is an output and cannot be set" in host.text()
    f.reset()
    host.init()
    with pytest.raises(FMICallException):
        f.getInt32([vr])
    assert "is of type Float64, not Int32" in host.text()
    f.reset()
    host.init()
    # NULL output arguments of fmi3DoStep
    out = fmi3Boolean()
    assert raw["fmi3DoStep"](f.component, 0.0, 1e-3, True, None, ctypes.byref(out), ctypes.byref(out), None) == 3
    # an FMI 2.0 instance's handle is not an FMI 3.0 instance (and is left alone)
    md2 = read_model_description(str(unzipped["bouncing_ball"]))
    two = FMU2Slave(guid=md2.guid, unzipDirectory=str(unzipped["bouncing_ball"]),
                    modelIdentifier=md2.coSimulation.modelIdentifier, instanceName="two")
    two.instantiate()
    last = fmi3Float64()
    assert raw["fmi3DoStep"](two.component, 0.0, 1e-3, True, ctypes.byref(out), ctypes.byref(out),
                             ctypes.byref(out), ctypes.byref(last)) == 3
    raw["fmi3FreeInstance"](two.component)
    two.setupExperiment(startTime=0.0)
    two.enterInitializationMode()
    two.exitInitializationMode()
    two.doStep(0.0, 1e-3)
    two.freeInstance()
    # the time is readable, not settable
    f.reset()
    host.init()
    f.doStep(0.0, 0.25)
    assert f.getFloat64([host.vr["time"]]) == [0.25]
    with pytest.raises(FMICallException):
        f.setFloat64([host.vr["time"]], [1.0])
    host.free()


def test_the_log_callback_is_fmi3s(fmus3, tmp_path):
    """FMI 3.0's logger takes the message as text (no printf format): a `%` arrives as it is."""
    host = Host3(fmus3["bouncing_ball"], tmp_path, instantiate=False)
    host.slave.instantiate(loggingOn=True, logMessage=host.log)
    assert any("fmi3InstantiateCoSimulation: contact-fmu" in m for _, _, m in host.messages)
    with pytest.raises(FMICallException):
        host.slave.setDebugLogging(True, ["100%s"])
    assert host.messages[-1][0] == 3 and '"100%s"' in host.messages[-1][2]
    host.free()


def test_the_step_budget_returns_early_with_a_warning_or_fails(fmus3, tmp_path):
    """FMI 3.0 allows fmi3Discard only for an FMU left as it was before the call. A step that
    reaches solver.max_steps integrator steps returns early, with fmi3Warning, when early
    return is allowed: the host goes on from lastSuccessfulTime and reaches the run of an
    unbudgeted host, bit for bit. Without early return the step fails (fmi3Error). Before, it
    returned fmi3Discard after moving on, and every later step was refused."""
    fmu, stop, h = fmus3["bouncing_ball"], 0.5, 0.05
    free = Host3(fmu, tmp_path, name="free", early_return=True)
    free.init()
    free_grid, _ = run_on_grid(free, stop, h)
    free.free()
    budget = Host3(fmu, tmp_path, name="budget", early_return=True)
    budget.init(**{"solver.max_steps": 3})
    grid, t, n, warned = [], 0.0, 0, 0
    while n < round(stop / h):
        target = (n + 1) * h
        before = len(budget.messages)
        _, terminate, early, last = budget.slave.doStep(t, target - t)
        assert not terminate
        if early:
            assert t < last < target
            new = budget.messages[before:]
            warned += any(s == 1 and "solver.max_steps = 3" in m for s, _, m in new)
            t = last
        else:
            t, n = target, n + 1
            grid.append(budget.outputs())
    assert warned > 10, warned
    assert grid == free_grid
    budget.free()
    strict = Host3(fmu, tmp_path, name="strict")
    strict.init(**{"solver.max_steps": 3})
    with pytest.raises(FMICallException):
        strict.slave.doStep(0.0, stop)
    assert strict.messages[-1][0] == 3 and "solver.max_steps = 3" in strict.messages[-1][2]
    strict.free()


def test_getters_read_start_values_before_initialisation(fmus3, fmus, unzipped, tmp_path):
    """FMI 3.0 lets a host read the start values in the instantiated state (section 2.3.2);
    before, the getters were refused there (FMI 2.0's rule) and the instance went to the error
    state. An FMI 2.0 instance still refuses them."""
    host = Host3(fmus3["bouncing_ball"], tmp_path)
    assert host.slave.getFloat64([host.vr["ball_floor.restitution"]]) == [0.8]
    height = host.slave.getFloat64([host.vr["ball.r[3]"]])[0]
    assert math.isfinite(height) and height > 0
    # the unused typed getters too (fmi3GetClock had FMI 2.0's mask: an error there)
    for name in ["fmi3GetInt8", "fmi3GetFloat32", "fmi3GetClock"]:
        getter = getattr(host.slave.dll, name)
        if name == "fmi3GetClock":
            status = getter(host.slave.component, None, ctypes.c_size_t(0), None)
        else:
            status = getter(host.slave.component, None, ctypes.c_size_t(0), None, ctypes.c_size_t(0))
        assert status == 0, name
    assert host.slave.getFloat64([host.vr["ball_floor.restitution"]]) == [0.8]
    host.init()
    assert host.slave.getFloat64([host.vr["ball.r[3]"]]) == [height]
    host.slave.doStep(0.0, 0.1)
    host.free()
    md2 = read_model_description(str(unzipped["bouncing_ball"]))
    two = FMU2Slave(guid=md2.guid, unzipDirectory=str(unzipped["bouncing_ball"]),
                    modelIdentifier=md2.coSimulation.modelIdentifier, instanceName="two")
    two.instantiate()
    with pytest.raises(FMICallException):
        two.getReal([md2.modelVariables[0].valueReference])
    two.freeInstance()


def test_debug_logging_switched_off_for_all_categories_logs_nothing(fmus3, tmp_path):
    """fmi3SetDebugLogging(false, 0, NULL) switches every category off (FMI: with no
    categories named, the switch applies to all), errors too; naming logStatusFatal then
    switches that one on alone; (true, 0, NULL) switches all on again. Before, errors were
    still logged after the first call."""
    host = Host3(fmus3["bouncing_ball"], tmp_path)
    host.init()
    f = host.slave

    def refused_step():
        before = len(host.messages)
        with pytest.raises(FMICallException):
            f.doStep(1.0, 0.1)  # not the current time: refused
        f.reset()
        host.init()
        return host.messages[before:]

    assert any(s == 3 for s, _, _ in refused_step())
    f.setDebugLogging(False, [])
    assert refused_step() == []
    f.setDebugLogging(True, ["logStatusFatal"])
    assert refused_step() == []
    f.setDebugLogging(True, [])
    assert any(s == 3 for s, _, _ in refused_step())
    host.free()


def test_a_tolerance_outside_the_range_of_solver_rtol_is_taken_at_its_bound(fmus3, fmus, unzipped, tmp_path):
    """A co-simulation FMU may ignore the host's tolerance (FMI 3.0 section 4.2.1): one
    outside solver.rtol's range [1e-14, 0.01] is taken as the nearest bound, with a warning,
    in both FMI versions. Before, the initialisation failed."""
    for tolerance, taken in [(0.1, 1e-2), (1e-16, 1e-14), (1e-5, 1e-5)]:
        host = Host3(fmus3["bouncing_ball"], tmp_path, name="tol")
        host.slave.enterInitializationMode(tolerance=tolerance, startTime=0.0)
        host.slave.exitInitializationMode()
        assert host.slave.getFloat64([host.vr["solver.rtol"]]) == [taken]
        warned = [m for s, _, m in host.messages if s == 1 and "solver.rtol's range" in m]
        assert len(warned) == (tolerance != taken), host.text()
        host.slave.doStep(0.0, 0.1)
        host.free()
    md2 = read_model_description(str(unzipped["bouncing_ball"]))
    rtol = next(v.valueReference for v in md2.modelVariables if v.name == "solver.rtol")
    two = FMU2Slave(guid=md2.guid, unzipDirectory=str(unzipped["bouncing_ball"]),
                    modelIdentifier=md2.coSimulation.modelIdentifier, instanceName="two")
    two.instantiate()
    two.setupExperiment(tolerance=0.1, startTime=0.0)
    two.enterInitializationMode()
    two.exitInitializationMode()
    assert two.getReal([rtol]) == [1e-2]
    two.freeInstance()


def test_a_step_that_reaches_no_further_is_discarded_and_the_instance_goes_on(fmus3, tmp_path):
    """Islands whose first round runs out of solver.max_steps are taken back to its start,
    the step's: the FMU is as it was before the call, which is when FMI 3.0 allows
    fmi3Discard. The instance stays in Step Mode, and a shorter step then gives what it gives
    in an instance that never tried the long one, bit for bit. (Before the first mend above,
    fmi3Discard left the instance unable to step; after it, an early return at the same time
    would have had the host repeat the same step for ever.)"""
    fmu = fmus3["pile_of_balls"]
    results = []
    for tried_first in (True, False):
        host = Host3(fmu, tmp_path, name="pile", early_return=True)
        host.init(**{"solver.max_steps": 1})
        if tried_first:
            with pytest.raises(FMICallException) as e:
                host.slave.doStep(0.0, 0.1)
            assert "status 2" in str(e.value)
            assert host.messages[-1][0] == 2 and "stopped at t = 0" in host.messages[-1][2]
        _, _, early, last = host.slave.doStep(0.0, 1e-4)
        assert (early, last) == (False, 1e-4)
        results.append(host.outputs())
        host.free()
    assert results[0] == results[1]
