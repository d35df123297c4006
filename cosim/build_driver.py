"""Builds the driver FMU (`cosim/driver/speed_controller.py`) with pythonfmu.

    .venv/bin/python cosim/build_driver.py [-o target/fmu/speed_controller.fmu]

The FMU runs its Python class in the Python of the process that loads it (fmpy, libcosimpy):
it needs a Python 3 with the shared `libpython` (any venv of the system Python has it).
"""

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SOURCE = ROOT / "cosim" / "driver" / "speed_controller.py"
DEFAULT_OUTPUT = ROOT / "target" / "fmu" / "speed_controller.fmu"
COMMON = ROOT / "cosim" / "sampled_slave.py"


def build(output=DEFAULT_OUTPUT, source=SOURCE):
    """Builds the FMU of the pythonfmu script `source` (default: the driver) at `output` (a path
    ending in .fmu); returns its path."""
    from pythonfmu import FmuBuilder

    output = Path(output)
    output.parent.mkdir(parents=True, exist_ok=True)
    if output.exists():
        output.unlink()  # pythonfmu takes an existing .fmu path for a file name only if it is a file
    # the base class the scripts share, beside the script in the FMU
    built = FmuBuilder.build_FMU(source, dest=output, project_files=[COMMON])
    # The builder imports the script as a module; forget it so that a later build (another
    # output path in the same process) imports the current source again.
    sys.modules.pop(Path(source).stem, None)
    return Path(built)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", type=Path, default=DEFAULT_OUTPUT)
    args = parser.parse_args()
    print(f"wrote {build(args.output)}")


if __name__ == "__main__":
    main()
