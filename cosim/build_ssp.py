"""Packs the co-simulation system into an `.ssp`: `cosim/system/SystemStructure.ssd` with the
exported rail vehicle FMU and the driver FMU.

    .venv/bin/python -m cosim.build_ssp [--vehicle target/fmu/rail_vehicle.fmu]
        [--driver target/fmu/speed_controller.fmu] [-o target/cosim/rail_vehicle_speed_control.ssp]

The vehicle FMU comes from `contact-fmu export fmu/rail_vehicle/scene.toml`; the driver is
built (`cosim/build_driver.py`) when `--driver` is not given or missing.
"""

import sys
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from cosim import build_driver  # noqa: E402
    from cosim.ssp import ROOT, pack_command, pack_ssp  # noqa: E402
else:
    from . import build_driver
    from .ssp import ROOT, pack_command, pack_ssp

DEFAULT_OUTPUT = ROOT / "target" / "cosim" / "rail_vehicle_speed_control.ssp"
VEHICLE = ROOT / "target" / "fmu" / "rail_vehicle.fmu"


def build(output=DEFAULT_OUTPUT, vehicle=VEHICLE, driver=None):
    if driver is None or not Path(driver).exists():
        driver = build_driver.build(driver or build_driver.DEFAULT_OUTPUT)
    return pack_ssp(
        output,
        {"resources/rail_vehicle.fmu": vehicle, "resources/speed_controller.fmu": driver},
    )


def main():
    pack_command(__doc__.splitlines()[0], build, VEHICLE, "driver", DEFAULT_OUTPUT)


if __name__ == "__main__":
    main()
