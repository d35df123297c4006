//! The scene builder against the scene file: what a builder leaves unset has the file's
//! defaults, and a built scene written as TOML parses back to the same scene, bit for bit.

use contact_fmu::bench::scenes;
use contact_fmu::scene::{
    BodySpec, ContactSpec, ImpulseMethod, InputSpec, JointSpec, JointType, Law, MaterialSpec, Method, Scene, Side,
    SpringDamperSpec, GROUND,
};
use contact_fmu::scene_builder::{Cylinder, Plane, SceneBuilder, Sphere};
use nalgebra::{UnitQuaternion, Vector3};

/// The TOML text of `scene` parses to a scene that is the same to the last bit (the debug
/// form shows every float exactly, the sign of zero included).
fn round_trips(scene: &Scene) {
    let text = scene.to_toml();
    let back = Scene::from_str(&text, "built.toml").unwrap_or_else(|e| panic!("{e}\n{text}"));
    assert_eq!(format!("{back:?}"), format!("{scene:?}"), "{text}");
}

#[test]
fn what_a_builder_leaves_out_has_the_scene_file_default() {
    // one table a line: only the keys without a default
    let text = r#"
model = { name = "minimal" }
body = [{ name = "ball", mass = 1.0, inertia = [0.1, 0.1, 0.1], position = [0.0, 0.0, 1.0] }]
joint = [{ name = "hinge", type = "revolute", parent = "ground", child = "ball", axis = [0.0, 1.0, 0.0] }]
spring_damper = [{ name = "spring", body_a = "ground", point_a = [0.0, 0.0, 2.0], body_b = "ball", point_b = [0.0, 0.0, 1.0], stiffness = 10.0 }]
contact = [{ name = "floor", type = "sphere_plane", law = "hertz", sphere_body = "ball", center = [0.0, 0.0, 1.0], radius = 0.1, body = "ground", origin = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 1.0], u_axis = [1.0, 0.0, 0.0], size = [1.0, 1.0], stiffness = 1e6 }]
input = [{ name = "push", type = "force", body = "ball", direction = [1.0, 0.0, 0.0] }]
"#;
    let parsed = Scene::from_str(text, "minimal.toml").unwrap();
    let ball = BodySpec::new("ball", 1.0, [0.1, 0.1, 0.1], [0.0, 0.0, 1.0]);
    let floor = Plane::horizontal([0.0; 3], [1.0, 1.0]);
    let built = SceneBuilder::new("minimal")
        .joint(JointSpec::new("hinge", JointType::Revolute, GROUND, "ball").axis([0.0, 1.0, 0.0]))
        .spring_damper(SpringDamperSpec::new(
            "spring",
            GROUND,
            [0.0, 0.0, 2.0],
            "ball",
            [0.0, 0.0, 1.0],
            10.0,
        ))
        .contact(ContactSpec::sphere_plane("floor", Law::Hertz, Sphere::of(&ball, 0.1), GROUND, floor).stiffness(1e6))
        .input(InputSpec::force("push", "ball", [1.0, 0.0, 0.0]))
        .body(ball)
        .build();
    assert_eq!(format!("{built:?}"), format!("{parsed:?}"));
    round_trips(&built);
}

#[test]
fn built_scenes_round_trip_through_toml() {
    // every kind of table and key the builder sets
    let q = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.3);
    let arm = BodySpec::new("arm", 2.0, [0.01, 0.2, 0.2], [0.5, 0.0, 0.0])
        .orientation(q)
        .velocity(Vector3::new(0.0, -0.0, 0.1))
        .angular_velocity([0.0, 0.2, 0.0]);
    let ball = BodySpec::sphere("ball", 0.0329, 0.01, [1.0, 0.0, 0.3]).velocity([0.0, 0.0, -1.0]);
    let groove = Cylinder::new([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], 0.5, 0.2);
    let scene = SceneBuilder::new("everything")
        .description("one of each")
        .gravity([0.0, 0.0, -9.81])
        .experiment(2.0, 1e-4)
        .solver(Method::Radau5, 1e-7, 1e-9, 1e-2)
        .steel()
        .material(MaterialSpec::new("rubber", 0.01e9, 0.49))
        .bodies([arm.clone(), ball.clone()])
        .joint(JointSpec::revolute("pivot", GROUND, "arm", [0.0; 3], [0.0, 1.0, 0.0]))
        .joint(JointSpec::new("tether", JointType::Free, "arm", "ball"))
        .spring_damper(
            SpringDamperSpec::new("link", "arm", [1.0, 0.0, 0.0], "ball", [1.0, 0.0, 0.3], 100.0)
                .damping(0.5)
                .free_length(0.25),
        )
        .contact(
            ContactSpec::sphere_sphere(
                "touch",
                Law::HertzLn,
                Sphere::new("arm", [1.0, 0.0, 0.0], 0.05),
                Sphere::of(&ball, 0.01),
            )
            .materials("steel", "rubber")
            .restitution(0.7)
            .exponent(1.5)
            .max_penetration(1e-3)
            .min_impact_velocity(1e-4),
        )
        .contact(
            ContactSpec::sphere_cylinder("groove", Law::Impulse, Sphere::of(&ball, 0.01), GROUND, groove)
                .side(Side::Inside)
                .theta_range([-1.0, 1.0], [0.0, 0.0, -1.0])
                .impulse_method(ImpulseMethod::EffectiveMass),
        )
        .contact(
            ContactSpec::sphere_plane(
                "wall",
                Law::KelvinVoigt,
                Sphere::of(&arm, 0.1),
                GROUND,
                Plane::new([2.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0]),
            )
            .stiffness(1e5)
            .damping(20.0),
        )
        .inputs([
            InputSpec::torque("motor", "arm", [0.0, 1.0, 0.0]).start(0.5),
            InputSpec::joint_force("drive", "pivot"),
        ])
        .build();
    scene.validate("everything.toml").unwrap();
    round_trips(&scene);
    // the benchmark scenes
    for scene in [
        scenes::ball_plane("ball", Law::Flores, 0.8, 1.0, 1e-3, false, 0.01, 1e-5),
        scenes::slow_touch(1e-8, 0.0),
        scenes::newtons_cradle(5, 0.1, 1e-5, Law::Hertz, 1.0, 3e-3),
        scenes::resting_bar(Law::HertzLn, 0.8, 3.0, 0.1),
        scenes::sphere_box(30, 0.05),
    ] {
        scene.validate(&scene.model.name).unwrap();
        round_trips(&scene);
    }
}
