#!/usr/bin/env python3
"""Writes the bundled pile_of_balls scene (fmu/pile_of_balls/scene.toml) from contact groups.

Usage: make_pile_of_balls.py [N_SIDE] [LAYERS] > scene.toml

N_SIDE x N_SIDE x LAYERS steel balls (radius 10 mm) start on a jittered lattice, 3 radii
apart sideways and 4 radii apart in height, with small sideways velocities, and fall into a
square box. One [[shape]] per ball and per wall and two [[contact_group]]s stand for the
pair list. The balls start as separate islands and merge into one as the pile forms.
"""
import math
import sys

n_side = int(sys.argv[1]) if len(sys.argv) > 1 else 3
layers = int(sys.argv[2]) if len(sys.argv) > 2 else 3
r = 0.01
m = 7850 * 4 / 3 * math.pi * r**3
inertia = 0.4 * m * r * r
half = 0.5 * n_side * 3.0 * r + 0.5 * r  # inner half-width of the box
n = n_side * n_side * layers
out = [f'''# {n} steel balls (radius 10 mm) dropped into a square box, built from contact groups: one
# [[shape]] per ball and per wall and two [[contact_group]]s instead of one [[contact]] per
# pair ({n * (n - 1) // 2 + 5 * n} pairs). The balls start on a jittered lattice, 3 radii apart sideways and 4
# apart in height, with small sideways velocities; they fall, collide, bounce and settle
# into a pile (Hertz contact with Lankarani-Nikravesh damping, e = 0.5). They start as {n}
# independent islands, which merge as the pile forms.
# Written by scripts/make_pile_of_balls.py {n_side} {layers}.
[model]
name = "pile_of_balls"
description = "{n} steel balls dropped into a square box (contact groups, independent islands)"
gravity = [0.0, 0.0, -9.81]
stop_time = 0.4
interval = 1e-3

[broad_phase]
margin = 0.002

[[material]]
name = "steel"
youngs_modulus = 210e9
poisson_ratio = 0.3
''']
k = 0
for layer in range(layers):
    for i in range(n_side):
        for j in range(n_side):
            k += 1
            jitter = 0.2 * r * math.sin(12.9898 * k)
            x = -half + 2.0 * r + 3.0 * r * i + jitter
            y = -half + 2.0 * r + 3.0 * r * j - jitter
            z = 2.0 * r + 4.0 * r * layer
            vx = 0.05 * math.sin(78.233 * k)
            vy = 0.05 * math.cos(39.425 * k)
            out.append(f'''[[body]]
name = "ball{k}"
mass = {m!r}
inertia = [{inertia!r}, {inertia!r}, {inertia!r}]
position = [{x!r}, {y!r}, {z!r}]
velocity = [{vx!r}, {vy!r}, 0.0]
''')
for k in range(1, n + 1):
    out.append(f'''[[shape]]
group = "balls"
type = "sphere"
body = "ball{k}"
radius = {r}
material = "steel"
''')
height = 2.0 * r + 4.0 * r * layers + 0.05
walls = [
    ([0.0, 0.0, 0.0], [0, 0, 1], [1, 0, 0]),
    ([-half, 0.0, 0.5 * height], [1, 0, 0], [0, 1, 0]),
    ([half, 0.0, 0.5 * height], [-1, 0, 0], [0, 1, 0]),
    ([0.0, -half, 0.5 * height], [0, 1, 0], [1, 0, 0]),
    ([0.0, half, 0.5 * height], [0, -1, 0], [1, 0, 0]),
]
for origin, normal, u in walls:
    size = [2 * half, 2 * half] if normal[2] else [2 * half, height]
    out.append(f'''[[shape]]
group = "box"
type = "plane"
body = "ground"
origin = [{origin[0]!r}, {origin[1]!r}, {origin[2]!r}]
normal = {normal}
u_axis = {u}
size = [{size[0]!r}, {size[1]!r}]
material = "steel"
''')
out.append('''[[contact_group]]
name = "ball_ball"
groups = ["balls", "balls"]
law = "hertz_ln"
restitution = 0.5

[[contact_group]]
name = "ball_box"
groups = ["balls", "box"]
law = "hertz_ln"
restitution = 0.5''')
print("\n".join(out))
