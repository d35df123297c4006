"""Parameter sweeps on dask.distributed (cosim/sweep.py, docs/sweeps.md): a LocalCluster of two
worker processes gives the same table as a serial run, bit for bit, whatever the batches of
cases its tasks run in one instance, and unpacks the FMU once per worker."""

import sys

import pytest

from conftest import ROOT

distributed = pytest.importorskip("distributed")  # ./run_tests.sh installs it
sys.path.insert(0, str(ROOT))
from cosim import sweep  # noqa: E402

PARAMS = {"ball_floor.restitution": [0.5, 0.8, 0.95], "ball_floor.law": [3, 4]}  # hertz_ln, hunt_crossley
OUTPUTS = ["ball.r[3]", "ball_floor.force", "energy.dissipated", "solver.steps"]


def bits(rows):
    return [{k: (float(v).hex() if isinstance(v, float) else v) for k, v in row.items()} for row in rows]


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    with distributed.Client(cluster) as c:
        yield c
    cluster.close()


def test_grid_is_the_cartesian_product_first_name_slowest():
    assert sweep.grid({"a": [1, 2], "b": [3, 4, 5]}) == [
        {"a": 1, "b": 3},
        {"a": 1, "b": 4},
        {"a": 1, "b": 5},
        {"a": 2, "b": 3},
        {"a": 2, "b": 4},
        {"a": 2, "b": 5},
    ]


def test_local_cluster_equals_serial_bit_for_bit(client, fmus, tmp_path):
    fmu = fmus["bouncing_ball"]
    cases = sweep.grid(PARAMS)
    serial = sweep.run_serial(fmu, cases, OUTPUTS, stop_time=0.5)
    parallel = sweep.run_dask(client, fmu, cases, OUTPUTS, stop_time=0.5)
    assert bits(parallel) == bits(serial)
    # The tasks run batches of cases in one instance, reset by fmi2Reset between them: the
    # default (two tasks per worker), one task for all six cases (five resets) and one case per
    # task give the serial run's table, whose every case has an instance of its own.
    assert sweep.batch_size(len(cases), 2) == 2
    for batch in (len(cases), 1):
        assert bits(sweep.run_dask(client, fmu, cases, OUTPUTS, stop_time=0.5, batch=batch)) == bits(serial)
    # The rows follow the cases, and the study means something: the ball dissipates more
    # energy in its impacts the lower the restitution, for each law.
    assert [{k: r[k] for k in PARAMS} for r in parallel] == cases
    for law in PARAMS["ball_floor.law"]:
        dissipated = [r["energy.dissipated"] for r in parallel if r["ball_floor.law"] == law]
        assert dissipated == sorted(dissipated, reverse=True) and dissipated[-1] > 0
    # Once per worker: each worker unpacked the FMU once, whatever the number of cases it ran.
    name = sweep.plugin_name(fmu)
    extractions = client.run(lambda dask_worker: dask_worker.plugins[name].runner.extractions)
    assert sorted(extractions.values()) == [1, 1]
    # The table and the plot.
    sweep.write_csv(parallel, tmp_path / "sweep.csv")
    lines = (tmp_path / "sweep.csv").read_text().splitlines()
    assert len(lines) == 1 + len(cases)
    assert lines[0].split(",")[:3] == ["ball_floor.restitution", "ball_floor.law", "ball.r[3]"]
    sweep.plot(parallel, list(PARAMS), "max(ball_floor.force)", tmp_path / "sweep.png")
    assert (tmp_path / "sweep.png").stat().st_size > 10_000


def test_wildcard_sets_every_matching_parameter(fmus, tmp_path):
    runner = sweep.FmuRunner(fmus["rail_vehicle"], tmp_path / "rail")
    assert runner.names("susp_*.damping") == [f"susp_{s}.damping" for s in ("fl", "fr", "rl", "rr")]
    with pytest.raises(KeyError):
        runner.names("no_such_*")
