"""Scene inputs seen from an FMI host (docs/scene.md, "Rules for names and numbers"): names at the
edge of the rule give FMUs that fmpy validates, and parameter values that the model cannot take
are refused at fmi2ExitInitializationMode with a message naming the parameter."""

import pytest
from fmpy import read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.validation import validate_fmu

from conftest import refused_at_exit_initialization, scene_path

FMI2_ERROR = 3


def bouncing_ball(**renames):
    text = scene_path("bouncing_ball").read_text()
    for old, new in renames.items():
        assert f'"{old}"' in text, old
        text = text.replace(f'"{old}"', f'"{new}"')
    return text


def test_names_at_the_edge_of_the_rule_give_an_fmu_that_fmpy_validates(export_scene):
    model = "m" + "_" * 199  # the longest model name
    text = bouncing_ball(bouncing_ball=model, steel="_s2", ball="B_1", ball_floor="_Ball_Floor_09")
    fmu, unzipdir = export_scene(text, "edge_names")
    assert validate_fmu(str(fmu)) == []
    md = read_model_description(str(unzipdir))
    assert md.coSimulation.modelIdentifier == model
    names = {v.name for v in md.modelVariables}
    assert {"B_1.r[3]", "_Ball_Floor_09.law", "_s2.youngs_modulus"} <= names
    assert (unzipdir / "binaries" / "linux64" / f"{model}.so").is_file()


def test_tolerance_ranges_are_in_the_model_description(unzipped):
    md = read_model_description(str(unzipped["bouncing_ball"]))
    v = {v.name: v for v in md.modelVariables}
    assert (float(v["solver.rtol"].min), float(v["solver.rtol"].max)) == (1e-14, 1e-2)
    assert (float(v["solver.atol"].min), float(v["solver.atol"].max)) == (1e-20, 1e-2)
    # max_step: 0 means none; a value between 0 and 1e-9 is refused when initialisation ends
    assert float(v["solver.max_step"].min) == 0.0


@pytest.mark.parametrize("variable,value,says", [
    ("solver.rtol", 0.5, "allowed range"),
    ("solver.atol", 1.0, "allowed range"),
    ("solver.max_step", 1e-12, "must be 0 (none) or finite and >= 1e-9 s"),
])
def test_a_tolerance_where_results_mean_nothing_is_refused(unzipped, make_instance, log, variable, value, says):
    inst = make_instance(unzipped["bouncing_ball"], "tolerance", callbacks=log.callbacks)
    assert refused_at_exit_initialization(inst, variable, value).status == FMI2_ERROR
    assert variable in log.text() and says in log.text(), log.text()


def test_kelvin_voigt_without_a_stiffness_names_the_parameter_and_what_to_do(unzipped, make_instance, log):
    # bouncing_ball's contact has no stiffness key: ball_floor.stiffness is a calculatedParameter
    md = read_model_description(str(unzipped["bouncing_ball"]))
    assert next(v for v in md.modelVariables if v.name == "ball_floor.stiffness").causality == "calculatedParameter"
    inst = make_instance(unzipped["bouncing_ball"], "kelvin_voigt", callbacks=log.callbacks)
    inst.slave.setupExperiment(startTime=0.0)
    inst.slave.enterInitializationMode()
    inst.set("ball_floor.law", 1)
    with pytest.raises(FMICallException) as raised:
        inst.slave.exitInitializationMode()
    assert raised.value.status == FMI2_ERROR
    text = log.text()
    for fragment in [
        'parameter "ball_floor.law" = 1 (kelvin_voigt)',
        '"ball_floor.stiffness" is a calculated parameter',
        "hertz = 2",
        "add stiffness",
        "export the FMU again",
    ]:
        assert fragment in text, text
    # another law works after a reset
    inst.slave.reset()
    inst.init(start_values={"ball_floor.law": 2})
    inst.step(1e-3)
