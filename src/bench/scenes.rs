//! Scenes generated for the benchmarks, built with [`SceneBuilder`] ([`Scene::to_toml`] writes
//! them as the files users write).

use crate::scene::{BodySpec, ContactGroupSpec, ContactSpec, JointSpec, Law, Method, Scene, ShapeSpec, GROUND};
use crate::scene_builder::{Plane, SceneBuilder, Sphere};

/// Radius of the benchmark's steel balls \[m\].
pub const BALL_RADIUS: f64 = 0.01;
/// Mass of the benchmark's steel balls \[kg\].
pub const BALL_MASS: f64 = 0.0329;

/// A steel ball (R = 10 mm, m = 0.0329 kg) centred at `position`.
fn steel_ball(name: &str, position: [f64; 3]) -> BodySpec {
    BodySpec::sphere(name, BALL_MASS, BALL_RADIUS, position)
}

/// A steel ball (R = 10 mm, m = 0.0329 kg) moving toward a steel plane at `speed` \[m/s\]
/// along −z, starting `gap` \[m\] above it. With `gravity` false the flight is uniform. The
/// contact, `floor`, is `contact[0]`: set more of its keys there.
#[allow(clippy::too_many_arguments)]
pub fn ball_plane(
    name: &str,
    law: Law,
    restitution: f64,
    speed: f64,
    gap: f64,
    gravity: bool,
    stop_time: f64,
    interval: f64,
) -> Scene {
    let ball = steel_ball("ball", [0.0, 0.0, BALL_RADIUS + gap]).velocity([0.0, 0.0, -speed]);
    SceneBuilder::new(name)
        .gravity([0.0, 0.0, if gravity { -9.81 } else { 0.0 }])
        .experiment(stop_time, interval)
        .solver(Method::Dopri5, 1e-8, 1e-10, 1e-3)
        .steel()
        .body(ball.clone())
        .contact(
            ContactSpec::sphere_plane(
                "floor",
                law,
                Sphere::of(&ball, BALL_RADIUS),
                GROUND,
                Plane::horizontal([0.0; 3], [1.0, 1.0]),
            )
            .restitution(restitution)
            .materials("steel", "steel"),
        )
        .build()
}

/// Hertz stiffness of the 10 mm steel ball of [`ball_plane`] on its steel plane (E = 210 GPa,
/// ν = 0.3) \[N/m^1.5\].
pub fn steel_ball_plane_stiffness() -> f64 {
    crate::contact::laws::hertz_stiffness(210e9, 0.3, 210e9, 0.3, 0.01)
}

/// The steel ball of [`ball_plane`] resting on the plane at its static Hertz penetration
/// under gravity (`hertz_ln`, e = 0.8), launched sliding along x at `speed` \[m/s\] without
/// spin, with friction `mu` (stiction velocity `stiction_velocity` \[m/s\]): it rolls from
/// t = 2 v0/(7 μ g) at 5/7 of `speed`.
pub fn sliding_ball(speed: f64, mu: f64, stiction_velocity: f64, stop_time: f64, interval: f64) -> Scene {
    let k = steel_ball_plane_stiffness();
    let delta0 = (BALL_MASS * 9.81 / k).powf(2.0 / 3.0);
    let mut scene = ball_plane("sliding", Law::HertzLn, 0.8, 0.0, -delta0, true, stop_time, interval);
    scene.body[0].velocity = [speed, 0.0, 0.0];
    let c = &mut scene.contact[0];
    c.friction = Some(mu);
    c.stiction_velocity = Some(stiction_velocity);
    c.size = Some([1e3, 1e3]);
    scene
}

/// The ball of [`ball_plane`] (`hertz_ln`, e = 0.8) touching the plane at `speed` \[m/s\] from
/// a gap of `speed` × 0.1 ms, under gravity, for 0.1 s in 1 ms steps; δ̇⁻ floored at
/// `min_impact_velocity` \[m/s\].
pub fn slow_touch(speed: f64, min_impact_velocity: f64) -> Scene {
    let mut scene = ball_plane("slow", Law::HertzLn, 0.8, speed, speed * 1e-4, true, 0.1, 1e-3);
    scene.contact[0].min_impact_velocity = Some(min_impact_velocity);
    scene
}

/// Newton's cradle: `n` free steel balls (R = 10 mm) in a row along x, `gap` \[m\] apart,
/// no gravity; the first moves at `speed` \[m/s\] toward the others. Contacts between
/// neighbours only.
pub fn newtons_cradle(n: usize, speed: f64, gap: f64, law: Law, restitution: f64, stop_time: f64) -> Scene {
    let balls: Vec<BodySpec> = (0..n)
        .map(|i| {
            let x = i as f64 * (2.0 * BALL_RADIUS + gap);
            steel_ball(&format!("b{i}"), [x, 0.0, 0.0]).velocity([if i == 0 { speed } else { 0.0 }, 0.0, 0.0])
        })
        .collect();
    let contacts: Vec<ContactSpec> = balls
        .windows(2)
        .enumerate()
        .map(|(i, pair)| {
            let [a, b] = [&pair[0], &pair[1]].map(|ball| Sphere::of(ball, BALL_RADIUS));
            ContactSpec::sphere_sphere(&format!("c{i}"), law, a, b)
                .restitution(restitution)
                .materials("steel", "steel")
        })
        .collect();
    SceneBuilder::new("newtons_cradle")
        .gravity([0.0; 3])
        .experiment(stop_time, 1e-5)
        .solver(Method::Dopri5, 1e-9, 1e-12, 1e-4)
        .steel()
        .bodies(balls)
        .contacts(contacts)
        .build()
}

/// A bar (1 kg, 0.5 m) pivoted at one end by a revolute joint about y, its loop closed by a
/// second, coaxial spherical joint (redundant rows), resting with a steel sphere at its free
/// end on a steel floor under gravity. For long resting-contact runs with a loop.
pub fn resting_bar(law: Law, restitution: f64, stop_time: f64, interval: f64) -> Scene {
    // Sphere radius 10 mm at x = 0.5, floor at z = 0: the pivot at z = 0.01 keeps the bar
    // horizontal when the sphere just touches; start with a tiny drop so that the contact
    // forms by a located touch.
    let drop = 1e-5;
    let zc = 0.01 + drop;
    SceneBuilder::new("resting_bar")
        .gravity([0.0, 0.0, -9.81])
        .experiment(stop_time, interval)
        .solver(Method::Dopri5, 1e-8, 1e-10, 1e-2)
        .steel()
        .body(BodySpec::new(
            "bar",
            1.0,
            [1e-4, 0.0209, 0.0209],
            [0.25, 0.0, 0.5 * (0.01 + zc)],
        ))
        .joint(JointSpec::revolute(
            "pivot",
            GROUND,
            "bar",
            [0.0, 0.0, 0.01],
            [0.0, 1.0, 0.0],
        ))
        .joint(JointSpec::spherical("pivot_loop", GROUND, "bar", [0.0, 0.05, 0.01]))
        .contact(
            ContactSpec::sphere_plane(
                "tip",
                law,
                Sphere::new("bar", [0.5, 0.0, zc], 0.01),
                GROUND,
                Plane::horizontal([0.5, 0.0, 0.0], [0.2, 0.2]),
            )
            .restitution(restitution)
            .materials("steel", "steel"),
        )
        .build()
}

/// `n` free spheres (R = 10 mm, 33 g, K = 1e7 N/m^1.5, hertz_ln e = 0.8) on a cubic lattice
/// of spacing 25 mm inside a box, with deterministic pseudo-random velocities of ~0.3 m/s,
/// no gravity. The scene format asks for every contact pair to be declared and has no broad
/// phase over undeclared pairs, so only lattice neighbours (6-neighbourhood) get a
/// sphere-sphere contact and only spheres on the lattice boundary get a contact with the wall
/// they face: valid while no sphere travels farther than one lattice spacing.
pub fn sphere_box(n: usize, stop_time: f64) -> Scene {
    let side = (n as f64).cbrt().ceil() as usize;
    let a = 0.025; // lattice spacing
    let r = BALL_RADIUS;
    let wall = 0.5 * a; // wall half a spacing beyond the outer lattice sites
    let idx = |i: usize, j: usize, k: usize| i + side * (j + side * k);
    let pos = |i: usize, j: usize, k: usize| [i as f64 * a, j as f64 * a, k as f64 * a];
    let exists = |i: usize, j: usize, k: usize| idx(i, j, k) < n;
    // the occupied lattice sites, in the order of their index
    let sites: Vec<(usize, usize, usize)> = (0..side)
        .flat_map(|k| (0..side).flat_map(move |j| (0..side).map(move |i| (i, j, k))))
        .filter(|&(i, j, k)| exists(i, j, k))
        .collect();
    let mut seed: u64 = 0x2545_f491_4f6c_dd1d;
    let mut rnd = || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let mut scene = SceneBuilder::new("sphere_box")
        .gravity([0.0; 3])
        .experiment(stop_time, 1e-3)
        .solver(Method::Dopri5, 1e-6, 1e-9, 1e-3);
    for &(i, j, k) in &sites {
        let v = [0.6 * rnd(), 0.6 * rnd(), 0.6 * rnd()];
        scene = scene.body(BodySpec::sphere(&format!("s{}", idx(i, j, k)), BALL_MASS, r, pos(i, j, k)).velocity(v));
    }
    let max = (side - 1) as f64 * a;
    let extent = max + 2.0 * wall;
    for &(i, j, k) in &sites {
        let me = idx(i, j, k);
        let sphere = || Sphere::new(&format!("s{me}"), pos(i, j, k), r);
        let hertz = |c: ContactSpec| c.restitution(0.8).stiffness(1e7);
        for (di, dj, dk) in [(1, 0, 0), (0, 1, 0), (0, 0, 1)] {
            let (i2, j2, k2) = (i + di, j + dj, k + dk);
            if i2 < side && j2 < side && k2 < side && exists(i2, j2, k2) {
                let other = idx(i2, j2, k2);
                let name = format!("c{me}_{other}");
                let neighbour = Sphere::new(&format!("s{other}"), pos(i2, j2, k2), r);
                scene = scene.contact(hertz(ContactSpec::sphere_sphere(
                    &name,
                    Law::HertzLn,
                    sphere(),
                    neighbour,
                )));
            }
        }
        // Walls: a sphere on the lattice boundary (or with no neighbour beyond it) faces the
        // wall on that side.
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
        for (w, (on, o, nrm, u)) in faces.into_iter().enumerate() {
            if on {
                let size = extent + 0.1;
                let plane = Plane::new(o, nrm, u, [size, size]);
                let name = format!("w{me}_{w}");
                scene = scene.contact(hertz(ContactSpec::sphere_plane(
                    &name,
                    Law::HertzLn,
                    sphere(),
                    GROUND,
                    plane,
                )));
            }
        }
    }
    scene.build()
}

/// The spheres and velocities of [`sphere_box`] with contact groups instead of a pair list:
/// every sphere in group `balls`, the six walls (one plane each, on the ground) in group
/// `walls`; group pairs `ball_ball` (balls, balls) and `ball_wall` (balls, walls), both
/// `hertz_ln` e = 0.8, K = 1e7 N/m^1.5. Every pair can touch (the broad phase finds those
/// within reach), so it stays valid however far the spheres travel.
pub fn sphere_box_groups(n: usize, stop_time: f64) -> Scene {
    let explicit = sphere_box(n, stop_time);
    let side = (n as f64).cbrt().ceil() as usize;
    let a = 0.025;
    let wall = 0.5 * a;
    let max = (side - 1) as f64 * a;
    let size = max + 2.0 * wall + 0.1;
    let mut scene = explicit;
    scene.contact.clear();
    scene.shape = scene
        .body
        .iter()
        .map(|b| ShapeSpec::sphere("balls", &b.name, b.position, BALL_RADIUS))
        .collect();
    let (lo, hi, mid) = (-wall, max + wall, 0.5 * max);
    for (o, nrm, u) in [
        ([lo, mid, mid], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        ([hi, mid, mid], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        ([mid, lo, mid], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]),
        ([mid, hi, mid], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]),
        ([mid, mid, lo], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]),
        ([mid, mid, hi], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]),
    ] {
        scene
            .shape
            .push(ShapeSpec::plane("walls", GROUND, Plane::new(o, nrm, u, [size, size])));
    }
    scene.contact_group = vec![
        ContactGroupSpec::new("ball_ball", "balls", "balls", Law::HertzLn)
            .restitution(0.8)
            .stiffness(1e7),
        ContactGroupSpec::new("ball_wall", "balls", "walls", Law::HertzLn)
            .restitution(0.8)
            .stiffness(1e7),
    ];
    scene
}
