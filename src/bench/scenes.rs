//! Scenes generated for the benchmarks (TOML text, the same format users write).

use std::fmt::Write;

/// Steel: E = 210 GPa, ν = 0.3.
const STEEL: &str = "[[material]]\nname = \"steel\"\nyoungs_modulus = 210e9\npoisson_ratio = 0.3\n";

/// A steel ball (R = 10 mm, m = 0.0329 kg) moving toward a steel plane at `speed` [m/s]
/// along −z, starting `gap` [m] above it. `extra` is appended to the contact (keys such as
/// `stiffness = 1e6`). With `gravity` false the flight is uniform.
#[allow(clippy::too_many_arguments)]
pub fn ball_plane(
    name: &str,
    law: &str,
    restitution: f64,
    speed: f64,
    gap: f64,
    gravity: bool,
    stop_time: f64,
    interval: f64,
    extra: &str,
) -> String {
    let r = 0.01;
    let z = r + gap;
    let g = if gravity { -9.81 } else { 0.0 };
    format!(
        r#"[model]
name = "{name}"
gravity = [0.0, 0.0, {g}]
stop_time = {stop_time:?}
interval = {interval:?}

[solver]
method = "dopri5"
rtol = 1e-8
atol = 1e-10
max_step = 1e-3

{STEEL}
[[body]]
name = "ball"
mass = 0.0329
inertia = [1.316e-6, 1.316e-6, 1.316e-6]
position = [0.0, 0.0, {z:?}]
velocity = [0.0, 0.0, {v:?}]

[[contact]]
name = "floor"
type = "sphere_plane"
law = "{law}"
restitution = {restitution:?}
sphere_body = "ball"
center = [0.0, 0.0, {z:?}]
radius = {r:?}
sphere_material = "steel"
body = "ground"
material = "steel"
origin = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
u_axis = [1.0, 0.0, 0.0]
size = [1.0, 1.0]
{extra}
"#,
        v = -speed
    )
}

/// Newton's cradle: `n` free steel balls (R = 10 mm) in a row along x, `gap` [m] apart,
/// no gravity; the first moves at `speed` [m/s] toward the others. Contacts between
/// neighbours only.
pub fn newtons_cradle(n: usize, speed: f64, gap: f64, law: &str, restitution: f64, stop_time: f64) -> String {
    let r = 0.01;
    let mut s = format!(
        "[model]\nname = \"newtons_cradle\"\ngravity = [0.0, 0.0, 0.0]\nstop_time = {stop_time:?}\ninterval = 1e-5\n\n\
         [solver]\nmethod = \"dopri5\"\nrtol = 1e-9\natol = 1e-12\nmax_step = 1e-4\n\n{STEEL}\n"
    );
    let x = |i: usize| i as f64 * (2.0 * r + gap);
    for i in 0..n {
        let v = if i == 0 { speed } else { 0.0 };
        let _ = writeln!(
            s,
            "[[body]]\nname = \"b{i}\"\nmass = 0.0329\ninertia = [1.316e-6, 1.316e-6, 1.316e-6]\n\
             position = [{:?}, 0.0, 0.0]\nvelocity = [{v:?}, 0.0, 0.0]\n",
            x(i)
        );
    }
    for i in 0..n.saturating_sub(1) {
        let _ = writeln!(
            s,
            "[[contact]]\nname = \"c{i}\"\ntype = \"sphere_sphere\"\nlaw = \"{law}\"\nrestitution = {restitution:?}\n\
             sphere_body = \"b{i}\"\ncenter = [{:?}, 0.0, 0.0]\nradius = {r:?}\nsphere_material = \"steel\"\n\
             body = \"b{}\"\nmaterial = \"steel\"\nother_center = [{:?}, 0.0, 0.0]\nother_radius = {r:?}\n",
            x(i),
            i + 1,
            x(i + 1)
        );
    }
    s
}

/// A bar (1 kg, 0.5 m) pivoted at one end by a revolute joint about y, its loop closed by a
/// second, coaxial spherical joint (redundant rows), resting with a steel sphere at its free
/// end on a steel floor under gravity. For long resting-contact runs with a loop.
pub fn resting_bar(law: &str, restitution: f64, stop_time: f64, interval: f64) -> String {
    // Sphere radius 10 mm at x = 0.5, floor at z = 0: the pivot at z = 0.01 keeps the bar
    // horizontal when the sphere just touches; start with a tiny drop so that the contact
    // forms by a located touch.
    let drop = 1e-5;
    let zc = 0.01 + drop;
    format!(
        r#"[model]
name = "resting_bar"
gravity = [0.0, 0.0, -9.81]
stop_time = {stop_time:?}
interval = {interval:?}

[solver]
method = "dopri5"
rtol = 1e-8
atol = 1e-10
max_step = 1e-2

{STEEL}
[[body]]
name = "bar"
mass = 1.0
inertia = [1e-4, 0.0209, 0.0209]
position = [0.25, 0.0, {zm:?}]

[[joint]]
name = "pivot"
type = "revolute"
parent = "ground"
child = "bar"
anchor = [0.0, 0.0, 0.01]
axis = [0.0, 1.0, 0.0]

[[joint]]
name = "pivot_loop"
type = "spherical"
parent = "ground"
child = "bar"
anchor = [0.0, 0.05, 0.01]

[[contact]]
name = "tip"
type = "sphere_plane"
law = "{law}"
restitution = {restitution:?}
sphere_body = "bar"
center = [0.5, 0.0, {zc:?}]
radius = 0.01
sphere_material = "steel"
body = "ground"
material = "steel"
origin = [0.5, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
u_axis = [1.0, 0.0, 0.0]
size = [0.2, 0.2]
"#,
        zm = 0.5 * (0.01 + zc)
    )
}

/// `n` free spheres (R = 10 mm, 33 g, K = 1e7 N/m^1.5, hertz_ln e = 0.8) on a cubic lattice
/// of spacing 25 mm inside a box, with deterministic pseudo-random velocities of ~0.3 m/s,
/// no gravity. The scene format asks for every contact pair to be declared and has no broad
/// phase over undeclared pairs, so only lattice neighbours (6-neighbourhood) get a
/// sphere-sphere contact and only spheres on the lattice boundary get a contact with the wall
/// they face: valid while no sphere travels farther than one lattice spacing.
pub fn sphere_box(n: usize, stop_time: f64) -> String {
    let side = (n as f64).cbrt().ceil() as usize;
    let a = 0.025; // lattice spacing
    let r = 0.01;
    let wall = 0.5 * a; // wall half a spacing beyond the outer lattice sites
    let idx = |i: usize, j: usize, k: usize| i + side * (j + side * k);
    let pos = |i: usize, j: usize, k: usize| [i as f64 * a, j as f64 * a, k as f64 * a];
    let exists = |i: usize, j: usize, k: usize| idx(i, j, k) < n;
    let mut s = format!(
        "[model]\nname = \"sphere_box\"\ngravity = [0.0, 0.0, 0.0]\nstop_time = {stop_time:?}\ninterval = 1e-3\n\n\
         [solver]\nmethod = \"dopri5\"\nrtol = 1e-6\natol = 1e-9\nmax_step = 1e-3\n\n"
    );
    let mut seed: u64 = 0x2545_f491_4f6c_dd1d;
    let mut rnd = || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    for k in 0..side {
        for j in 0..side {
            for i in 0..side {
                if !exists(i, j, k) {
                    continue;
                }
                let p = pos(i, j, k);
                let v = [0.6 * rnd(), 0.6 * rnd(), 0.6 * rnd()];
                let _ = writeln!(
                    s,
                    "[[body]]\nname = \"s{}\"\nmass = 0.0329\ninertia = [1.316e-6, 1.316e-6, 1.316e-6]\n\
                     position = [{:?}, {:?}, {:?}]\nvelocity = [{:?}, {:?}, {:?}]\n",
                    idx(i, j, k),
                    p[0],
                    p[1],
                    p[2],
                    v[0],
                    v[1],
                    v[2]
                );
            }
        }
    }
    let contact_head = |s: &mut String, name: String, body: usize, p: [f64; 3]| {
        let _ =
            write!(
            s,
            "[[contact]]\nname = \"{name}\"\ntype = \"{}\"\nlaw = \"hertz_ln\"\nrestitution = 0.8\nstiffness = 1e7\n\
             sphere_body = \"s{body}\"\ncenter = [{:?}, {:?}, {:?}]\nradius = {r:?}\n",
            if name.starts_with('w') { "sphere_plane" } else { "sphere_sphere" },
            p[0],
            p[1],
            p[2]
        );
    };
    let max = (side - 1) as f64 * a;
    let extent = max + 2.0 * wall;
    for k in 0..side {
        for j in 0..side {
            for i in 0..side {
                if !exists(i, j, k) {
                    continue;
                }
                let me = idx(i, j, k);
                let p = pos(i, j, k);
                for (di, dj, dk) in [(1, 0, 0), (0, 1, 0), (0, 0, 1)] {
                    let (i2, j2, k2) = (i + di, j + dj, k + dk);
                    if i2 < side && j2 < side && k2 < side && exists(i2, j2, k2) {
                        let q = pos(i2, j2, k2);
                        contact_head(&mut s, format!("c{me}_{}", idx(i2, j2, k2)), me, p);
                        let _ = writeln!(
                            s,
                            "body = \"s{}\"\nother_center = [{:?}, {:?}, {:?}]\nother_radius = {r:?}\n",
                            idx(i2, j2, k2),
                            q[0],
                            q[1],
                            q[2]
                        );
                    }
                }
                // Walls: a sphere on the lattice boundary (or with no neighbour beyond it)
                // faces the wall on that side.
                let faces = [
                    (i == 0, [-wall, 0.5 * max, 0.5 * max], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
                    (
                        i + 1 == side || !exists(i + 1, j, k),
                        [max + wall, 0.5 * max, 0.5 * max],
                        [-1.0, 0.0, 0.0],
                        [0.0, 1.0, 0.0],
                    ),
                    (j == 0, [0.5 * max, -wall, 0.5 * max], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]),
                    (
                        j + 1 == side || !exists(i, j + 1, k),
                        [0.5 * max, max + wall, 0.5 * max],
                        [0.0, -1.0, 0.0],
                        [0.0, 0.0, 1.0],
                    ),
                    (k == 0, [0.5 * max, 0.5 * max, -wall], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]),
                    (
                        k + 1 == side || !exists(i, j, k + 1),
                        [0.5 * max, 0.5 * max, max + wall],
                        [0.0, 0.0, -1.0],
                        [1.0, 0.0, 0.0],
                    ),
                ];
                for (w, (on, o, nrm, u)) in faces.iter().enumerate() {
                    if !on {
                        continue;
                    }
                    contact_head(&mut s, format!("w{me}_{w}"), me, p);
                    let _ = writeln!(
                        s,
                        "body = \"ground\"\norigin = [{:?}, {:?}, {:?}]\nnormal = [{:?}, {:?}, {:?}]\n\
                         u_axis = [{:?}, {:?}, {:?}]\nsize = [{e:?}, {e:?}]\n",
                        o[0],
                        o[1],
                        o[2],
                        nrm[0],
                        nrm[1],
                        nrm[2],
                        u[0],
                        u[1],
                        u[2],
                        e = extent + 0.1
                    );
                }
            }
        }
    }
    s
}
