"""The integrator continues across communication points (the default): stepped through fmpy's
FMU2Slave with no input or parameter changed, every bundled FMU does the same work at a
communication step of 1e-4 s as at 1e-2 s, and the results agree within the tolerance."""

import pytest

SCENES = ["bouncing_ball", "rail_vehicle", "slider_crank", "two_spheres"]


def run(make_instance, unzipdir, h, stop):
    """Steps to `stop` in steps of `h`; returns the RHS count and the outputs (as numbers) at
    the multiples of 0.01 s."""
    inst = make_instance(unzipdir, f"continuation_{h}")
    inst.init()
    every = round(0.01 / h)
    n = round(stop / h)
    names = [v.name for v in inst.md.modelVariables
             if v.causality == "output" and v.type == "Real" and not v.name.startswith("solver.")]
    rows = []
    for k in range(1, n + 1):
        inst.step(h)
        if k % every == 0:
            rows.append([inst.get(name) for name in names])
    return inst.get("solver.rhs_evals"), names, rows


@pytest.mark.parametrize("scene", SCENES)
def test_work_does_not_depend_on_the_communication_step(unzipped, make_instance, scene):
    d = unzipped[scene]
    stop = 0.01 if scene == "two_spheres" else 0.4
    fine, names, a = run(make_instance, d, 1e-4, stop)
    coarse, _, b = run(make_instance, d, 1e-2, stop)
    ratio = fine / coarse
    worst = 0.0
    for j, name in enumerate(names):
        col = [r[j] for r in a]
        span = max(col) - min(col)
        if span > 0:
            worst = max(worst, max(abs(x[j] - y[j]) for x, y in zip(a, b)) / span)
    print(f"{scene}: {fine} RHS at 1e-4 s, {coarse} at 1e-2 s (ratio {ratio:.3f}); largest difference {worst:.1e}")
    assert len(a) == len(b)
    assert 1 / 1.2 <= ratio <= 1.2, f"{scene}: {fine} RHS at 1e-4 s against {coarse} at 1e-2 s"
    assert worst < 1e-5, f"{scene}: outputs differ by {worst:.1e} of their range"
