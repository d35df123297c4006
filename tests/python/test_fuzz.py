"""Random FMI call sequences against the exported FMUs (scripts/fuzz_fmi.py; the FMI 3.0
functions of target/fmu3 with scripts/fuzz_fmi3.py): no crash, no hang, no NaN or infinity
read after an OK status, every status within the status enumeration.

The seeds are fixed, so a failure is reproduced with `python scripts/fuzz_fmi.py --seed N
--verbose`. The long campaign is a benchmark (`--sequences 100000`, docs/robustness.md).
"""

import sys

import pytest

from conftest import ROOT

sys.path.insert(0, str(ROOT / "scripts"))
import fuzz_fmi  # noqa: E402
import fuzz_fmi3  # noqa: E402

SEQUENCES = 300
# the FMI 3.0 share (the functions of both versions drive one instance type, glue aside)
SEQUENCES3 = 300
# An fmi2DoStep longer than this counts as a violation here (the campaign reports those over
# 1 s); an unbounded step would take far longer.
SLOW_STEP_SECONDS = 5.0


def failures(results, fmi_version=2):
    """Every violation of every sequence, with the command that replays it."""
    replay = "python scripts/fuzz_fmi3.py" if fmi_version == 3 else "python scripts/fuzz_fmi.py"
    return [
        f"seed {r['seed']}: {v[0]} at call {v[1]}: {v[2]} (replay: {replay} --seed {r['seed']})"
        for r in results
        for v in r["violations"]
    ]


def test_random_call_sequences_neither_crash_hang_nor_give_nan_after_ok(fmus):
    results = fuzz_fmi.campaign(
        list(fmus.values()), range(SEQUENCES), jobs=2, timeout=60.0, slow=SLOW_STEP_SECONDS
    )
    assert len(results) == SEQUENCES
    found = failures(results)
    assert not found, "\n".join(found[:20])
    summary = fuzz_fmi.summarize(results)
    # the sequences reach the running states: steps succeed and overlong ones are discarded
    steps = summary["functions"]["fmi2DoStep"]["status"]
    assert steps.get("0", 0) > 500 and steps.get("2", 0) > 0, steps
    assert all(summary["functions"][name]["calls"] > 0 for name in fuzz_fmi.FUNCTIONS)


@pytest.mark.parametrize("inject", ["crash", "hang", "nan"])
def test_the_oracles_catch_a_crash_a_hang_and_a_nan(fmus, inject):
    results = fuzz_fmi.campaign(list(fmus.values())[:1], range(2), jobs=1, timeout=3.0, inject=inject)
    summary = fuzz_fmi.summarize(results)
    kind = {"crash": "crash", "hang": "hang", "nan": "nan_after_ok"}[inject]
    assert summary["counts"][kind] == 2, summary["counts"]
    assert summary["bad_seeds"][kind] == [0, 1]


def test_fmi3_call_sequences_neither_crash_hang_nor_give_nan_after_ok(fmus3):
    results = fuzz_fmi.campaign(
        list(fmus3.values()), range(SEQUENCES3), jobs=2, timeout=60.0, slow=SLOW_STEP_SECONDS, fmi_version=3
    )
    assert len(results) == SEQUENCES3
    found = failures(results, 3)
    assert not found, "\n".join(found[:20])
    summary = fuzz_fmi.summarize(results, fuzz_fmi3.FUNCTIONS3)
    steps = summary["functions"]["fmi3DoStep"]["status"]
    assert steps.get("0", 0) > 300 and steps.get("3", 0) > 0, steps
    assert all(summary["functions"][name]["calls"] > 0 for name in fuzz_fmi3.FUNCTIONS3)
