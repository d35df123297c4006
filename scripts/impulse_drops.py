#!/usr/bin/env python3
"""Random drops of a ball onto a cylinder under the impulse law: how many pass its wall.

A steel ball (radius 10 mm, 32.9 g) is dropped with 0.1 m/s along the axis of a cylinder of
radius 50 mm along y through the origin (tests/integration/scenes/ball_and_cylinder.toml,
the scene of the regression test), inside it (a groove: the ball starts within 39 mm of the
axis, below it) or onto it (a bump: the ball starts 62-112 mm above the axis, within 15 mm to
either side), with a restitution drawn from [0.3, 0.95], and runs 0.6 s with
`contact-fmu simulate` (1 ms outputs). A drop passes the wall when the ball's centre comes
more than 1e-7 m beyond rho - R (groove) or inside rho + R (bump). The figures of
docs/contact.md ("A return after an impact, and grazes under the impulse law"):

    .venv/bin/python scripts/impulse_drops.py --side inside --drops 300 --seed 3
    .venv/bin/python scripts/impulse_drops.py --side outside --drops 300 --seed 1
    .venv/bin/python scripts/impulse_drops.py --side outside --drops 300 --seed 2

(`--binary` another build's `contact-fmu` to compare.)
"""
import argparse
import csv
import math
import os
import random
import subprocess
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# the scene of the regression test, whose drop lines are replaced
SCENE = os.path.join(ROOT, "tests", "integration", "scenes", "ball_and_cylinder.toml")


def scene_text(x, z, e, side):
    """The scene with the ball dropped from (x, 0, z), restitution e, the cylinder's side."""
    lines = []
    with open(SCENE) as f:
        for line in f.read().splitlines():
            key = line.split(" = ")[0]
            if key in ("position", "center"):
                line = f"{key} = [{x!r}, 0.0, {z!r}]"
            elif key == "restitution":
                line = f"restitution = {e!r}"
            elif key == "side":
                line = f'side = "{side}"'
            lines.append(line)
    return "\n".join(lines) + "\n"


def drop(rng, side):
    """A random start (x, z) and restitution e."""
    if side == "outside":
        x, z = rng.uniform(-0.015, 0.015), rng.uniform(0.062, 0.112)
    else:
        angle, r0 = rng.uniform(0.3, 1.3), rng.uniform(0.0, 0.039)
        x, z = r0 * math.cos(angle), -r0 * math.sin(angle)
    return x, z, rng.uniform(0.3, 0.95)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--side", choices=["inside", "outside"], default="inside")
    parser.add_argument("--drops", type=int, default=100)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--binary", default=os.path.join(ROOT, "target", "release", "contact-fmu"))
    args = parser.parse_args()
    rng = random.Random(args.seed)
    passed = failed = 0
    with tempfile.TemporaryDirectory() as work:
        scene, out = os.path.join(work, "drop.toml"), os.path.join(work, "drop.csv")
        for k in range(args.drops):
            x, z, e = drop(rng, args.side)
            with open(scene, "w") as f:
                f.write(scene_text(x, z, e, args.side))
            command = [args.binary, "simulate", scene, "--csv", out, "--quiet"]
            run = subprocess.run(command, capture_output=True, text=True)
            if run.returncode != 0:
                failed += 1
                print(f"drop {k}: exit {run.returncode}: {run.stderr.strip()[-200:]}")
                continue
            with open(out) as f:
                rows = list(csv.DictReader(f))
            distance = [math.hypot(float(r["ball.r[1]"]), float(r["ball.r[3]"])) for r in rows]
            beyond = 0.06 - min(distance) if args.side == "outside" else max(distance) - 0.04
            if beyond > 1e-7:
                passed += 1
                where = f"x = {x!r}, z = {z!r}, e = {e!r}"
                print(f"drop {k}: {where}: {beyond * 1e3:.3f} mm beyond the wall")
    summary = f"{passed} of {args.drops} drops passed the wall ({failed} runs failed)"
    print(f"{args.side}, seed {args.seed}: {summary}")


if __name__ == "__main__":
    main()
