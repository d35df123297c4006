"""`solver.method = auto` (the default) through fmpy: every bundled FMU starts with it; on the
rail vehicle, whose wheel-rail contacts make it stiff, it switches to the implicit method and
does a fraction of Dormand-Prince's work for the same trajectory; on the scenes that are never
stiff it is Dormand-Prince step for step; and the other methods stay selectable by number."""

import pytest

SCENES = ["bouncing_ball", "rail_vehicle", "slider_crank", "two_spheres"]
AUTO, DOPRI5, RADAU5 = 5, 1, 4


def run(make_instance, unzipdir, method, stop, h=0.01, tolerances=None):
    """Steps to `stop` with `method` (None: the FMU's default) and the start values
    `tolerances` (None: the FMU's); returns the counters and the car-body (or first body)
    height at every communication point."""
    inst = make_instance(unzipdir, f"auto_{method}")
    start = dict(tolerances or {})
    if method is not None:
        start["solver.method"] = method
    inst.init(start_values=start)
    height = next(v.name for v in inst.md.modelVariables if v.name.endswith(".r[3]"))
    z = []
    for _ in range(round(stop / h)):
        inst.step(h)
        z.append(inst.get(height))
    counters = {k: inst.get(f"solver.{k}") for k in ("steps", "rhs_evals")}
    return inst.get("solver.method"), counters, z


@pytest.mark.parametrize("scene", SCENES)
def test_auto_is_the_default_method(unzipped, make_instance, scene):
    inst = make_instance(unzipped[scene], "default_method")
    assert inst.vars["solver.method"].start in ("5", 5)
    inst.init()
    assert inst.get("solver.method") == AUTO


def test_auto_switches_on_the_stiff_rail_vehicle_and_does_far_less_work(unzipped, make_instance):
    d = unzipped["rail_vehicle"]
    # (the scene's own tolerances are loose, rtol 4e-6: both runs at rtol 1e-8)
    tight = {"solver.rtol": 1e-8, "solver.atol": 1e-10}
    method, auto, z_auto = run(make_instance, d, None, 5.0, tolerances=tight)
    assert method == AUTO
    _, dopri5, z_dopri5 = run(make_instance, d, DOPRI5, 5.0, tolerances=tight)
    span = max(z_dopri5) - min(z_dopri5)
    worst = max(abs(a - b) for a, b in zip(z_auto, z_dopri5)) / span
    print(f"rail vehicle, 5 s: auto {auto}, dopri5 {dopri5}; heights differ by {worst:.1e} of their range")
    # Dormand-Prince sits at its stability limit; the implicit method steps over the
    # wheel-on-rail mode
    assert 5 * auto["rhs_evals"] < dopri5["rhs_evals"]
    # both at rtol 1e-8: the same trajectory within the tolerance
    assert worst < 1e-7


@pytest.mark.parametrize("scene", ["bouncing_ball", "slider_crank", "two_spheres"])
def test_auto_is_dormand_prince_on_scenes_that_are_never_stiff(unzipped, make_instance, scene):
    d = unzipped[scene]
    stop = 0.01 if scene == "two_spheres" else 0.3
    h = 1e-3 if scene == "two_spheres" else 0.01
    _, auto, z_auto = run(make_instance, d, None, stop, h)
    _, dopri5, z_dopri5 = run(make_instance, d, DOPRI5, stop, h)
    assert auto == dopri5
    assert z_auto == z_dopri5


def test_every_method_stays_selectable(unzipped, make_instance):
    d = unzipped["bouncing_ball"]
    for method in (DOPRI5, 2, 3, RADAU5, AUTO):
        got, counters, z = run(make_instance, d, method, 0.05)
        assert got == method
        assert counters["steps"] > 0 and all(abs(x) < 10 for x in z)
