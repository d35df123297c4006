"""The islands side by side inside a host: the bundled pile exported with `[solver] threads = 2`
(its islands of a round advanced on two threads inside `fmi2DoStep`, joined before the call
returns) gives fmpy the same outputs bit for bit as the bundled FMU on one thread."""

import numpy as np
from fmpy import simulate_fmu

from conftest import scene_path


def test_the_pile_on_two_threads_gives_the_outputs_of_one(fmus, export_scene):
    text = scene_path("pile_of_balls").read_text() + "\n[solver]\nthreads = 2\n"
    fmu, _ = export_scene(text, "pile_of_balls_threads")
    kwargs = dict(stop_time=0.3, output_interval=0.003)
    one = simulate_fmu(str(fmus["pile_of_balls"]), **kwargs)
    two = simulate_fmu(str(fmu), **kwargs)
    assert one.dtype.names == two.dtype.names
    assert len(one) == len(two) == 101
    for name in one.dtype.names:
        assert np.array_equal(one[name], two[name]), name
