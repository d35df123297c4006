"""A step that blows up is refused at that step (docs/robustness.md): an integration whose state
runs away (the slider-crank under rk4 with a 10 ms step: its block's impact is far too stiff for
it) or whose energy balance grows beyond ten times its scale (the bouncing ball at the loosest
tolerances allowed, rtol = atol = 1e-2)
ends the step with fmi2Error and a message naming the cause and the remedy, before any output
carries inf; `contact-fmu simulate` stops there, writes no row of inf, and exits non-zero; a run
that drifts by more than 1 % exits non-zero unless --allow-energy-drift. The energy watch is part
of the FMU state: an instance given a serialized state warns and refuses where the one that saved
it does."""

import csv
import math
import subprocess

import pytest
from fmpy.fmi1 import FMICallException

from conftest import BINARY, ROOT, LogCapture, scene_path


def real_outputs(inst):
    return [v.name for v in inst.md.modelVariables if v.causality == "output" and v.type == "Real"]


@pytest.mark.parametrize("scene,settings,says", [
    ("slider_crank", {"solver.method": 3, "solver.max_step": 1e-2}, "rk4 with a step of 0.01 s is unstable"),
    ("bouncing_ball", {"solver.rtol": 1e-2, "solver.atol": 1e-2}, "tighten solver.rtol"),
])
def test_fmi2_do_step_refuses_the_step_that_blows_up(unzipped, make_instance, log, scene, settings, says):
    inst = make_instance(unzipped[scene], "blow-up", callbacks=log.callbacks)
    inst.init(settings)
    names = real_outputs(inst)
    h = 1e-3
    refused = False
    # up to 5 s: the ball at rtol 1e-2 crosses ten times its energy scale at 3.2 s (its
    # dissipated energy grows to 11 times its initial energy), the slider-crank blows up at its
    # block's first impact
    for _ in range(5000):
        values = [inst.get(n) for n in names]
        assert all(math.isfinite(x) for x in values), "an output is not finite after fmi2OK"
        try:
            inst.step(h)
        except FMICallException as e:
            assert e.status == 3  # fmi2Error
            refused = True
            break
    assert refused, "the run did not blow up"
    assert "blew up" in log.text() and says in log.text(), log.text()
    # the outputs are still readable and finite
    assert all(math.isfinite(inst.get(n)) for n in names)


def test_simulate_stops_at_the_blow_up_without_inf_rows(tmp_path):
    out = tmp_path / "rk4.csv"
    result = subprocess.run(
        [str(BINARY), "simulate", str(scene_path("slider_crank")), "--set", "solver.method=rk4",
         "--set", "solver.max_step=1e-2", "--csv", str(out)],
        cwd=ROOT, capture_output=True, text=True,
    )
    assert result.returncode != 0
    assert "blew up" in result.stderr and "rk4" in result.stderr, result.stderr
    rows = list(csv.reader(out.open()))
    assert len(rows) > 10
    assert not any("inf" in cell or "nan" in cell.lower() for row in rows[1:] for cell in row)


def test_simulate_exits_non_zero_on_energy_drift_unless_allowed(tmp_path):
    # rk4 at 30 us drifts by 15 % over 0.5 s: inaccurate, not a blow-up
    args = [str(BINARY), "simulate", str(scene_path("bouncing_ball")), "--set", "solver.method=rk4",
            "--set", "solver.max_step=3e-5", "--stop-time", "0.5", "--csv", str(tmp_path / "drift.csv")]
    result = subprocess.run(args, cwd=ROOT, capture_output=True, text=True)
    assert result.returncode != 0
    assert "drifted" in result.stderr and "--allow-energy-drift" in result.stderr, result.stderr
    allowed = subprocess.run(args + ["--allow-energy-drift"], cwd=ROOT, capture_output=True, text=True)
    assert allowed.returncode == 0, allowed.stderr
    assert "warning" in allowed.stderr and "drifted" in allowed.stderr
    assert (tmp_path / "drift.csv").stat().st_size > 0


def steps_until(inst, log, stop, h=1e-3):
    """Steps `inst` to `stop` (or until a step is refused): the time of the refused step (None:
    none), and the warnings and errors logged on the way (their texts)."""
    log.clear()
    refused_at = None
    while inst.time < stop - h / 2:
        try:
            inst.step(h)
        except FMICallException as e:
            assert e.status == 3  # fmi2Error
            refused_at = inst.time
            break

    def said(status):
        return [m[2] for m in log.messages if m[0] == status]

    return refused_at, said(1), said(3)  # fmi2Warning, fmi2Error


@pytest.mark.parametrize("max_step,saved_at", [(3e-5, 0.15), (1e-4, 0.1)])
def test_a_restored_fmu_state_warns_and_refuses_where_the_saving_run_does(unzipped, make_instance, max_step, saved_at):
    # the bouncing ball under rk4: at a 30 us step it warns of the energy drift at its first
    # impact (0.143 s) and runs on, at 100 us it blows up there. The energy watch is part of the
    # FMU state: an instance given the state (saved after the warning, or before the impact)
    # warns and refuses exactly where the one that saved it does
    settings = {"solver.method": 3, "solver.max_step": max_step}
    # (one logger at a time: fmpy's proxy formats the messages of the last one registered)
    logs = [LogCapture()]
    a = make_instance(unzipped["bouncing_ball"], "a", callbacks=logs[0].callbacks)
    a.init(settings)
    for _ in range(round(saved_at / 1e-3)):
        a.step(1e-3)
    warned_before = any(m[0] == 1 and "drifted" in m[2] for m in logs[0].messages)
    assert warned_before == (max_step == 3e-5), logs[0].text()  # the premise of each case
    state = a.slave.getFMUstate()
    data = a.slave.serializeFMUstate(state)
    a.slave.freeFMUstate(state)
    t_saved = a.time
    expected = steps_until(a, logs[0], 1.0)
    expected_outputs = a.outputs()

    logs.append(LogCapture())
    b = make_instance(unzipped["bouncing_ball"], "b", callbacks=logs[1].callbacks)
    restored = b.slave.deSerializeFMUstate(data)
    b.slave.setFMUstate(restored)
    b.slave.freeFMUstate(restored)
    b.time = t_saved
    got = steps_until(b, logs[1], 1.0)
    assert got == expected
    assert b.outputs() == expected_outputs  # bit for bit
    refused_at, warnings, errors = got
    if max_step == 1e-4:
        assert refused_at is not None and any("blew up" in e for e in errors), got
    else:
        # warned before the save: not again
        assert refused_at is None and warnings == [] and errors == [], got
