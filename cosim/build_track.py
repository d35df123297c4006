"""Builds the track FMU (`cosim/track/track_irregularity.py`, with pythonfmu) and packs the system
of the rail vehicle over a track irregularity into an `.ssp`: `cosim/track/SystemStructure.ssd`
with the exported vehicle FMU and the track FMU.

    .venv/bin/python -m cosim.build_track [--vehicle target/fmu/rail_vehicle_track.fmu]
        [--track target/fmu/track_irregularity.fmu] [-o target/cosim/rail_vehicle_track.ssp]

The vehicle FMU comes from `contact-fmu export fmu/rail_vehicle_track/scene.toml` (the main job
`cargo run --release` exports it); the track FMU is built when `--track` is not given or missing.
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

TRACK_DIR = ROOT / "cosim" / "track"
SOURCE = TRACK_DIR / "track_irregularity.py"
SSD = TRACK_DIR / "SystemStructure.ssd"
VEHICLE = ROOT / "target" / "fmu" / "rail_vehicle_track.fmu"
TRACK = ROOT / "target" / "fmu" / "track_irregularity.fmu"
DEFAULT_OUTPUT = ROOT / "target" / "cosim" / "rail_vehicle_track.ssp"


def build_track_fmu(output=TRACK):
    """Builds the track FMU at `output`; returns its path."""
    return build_driver.build(output, SOURCE)


def build(output=DEFAULT_OUTPUT, vehicle=VEHICLE, track=None, ssd=SSD):
    """Packs `ssd` (default: the system's SSD) with the two FMUs into the `.ssp` `output`."""
    if track is None or not Path(track).exists():
        track = build_track_fmu(track or TRACK)
    return pack_ssp(
        output,
        {"resources/rail_vehicle_track.fmu": vehicle, "resources/track_irregularity.fmu": track},
        ssd,
    )


def main():
    pack_command(__doc__.splitlines()[0], build, VEHICLE, "track", DEFAULT_OUTPUT)


if __name__ == "__main__":
    main()
