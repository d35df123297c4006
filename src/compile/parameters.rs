//! Parameter values: the numbers of a scene that a host may set before initialisation
//! (materials, masses and inertias, contact geometry and law constants, springs, initial
//! velocities, solver settings, input start values; the contact-law constants also after it,
//! see `Simulation::set`). The
//! scene gives their defaults; [`super::compile`] reads them from here, so that changing a
//! parameter never edits the scene.

use crate::contact::Friction;
use crate::model::contact::LawConstants;
use crate::scene::{
    check_law, check_max_step, inertia_is_physical, item_name, ContactGroupSpec, ContactSpec, ContactType, Law, Scene,
    SceneError, Side, SolverSection,
};

/// Elastic constants of a material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MaterialValues {
    /// Young's modulus E \[Pa\].
    pub youngs_modulus: f64,
    /// Poisson's ratio ν.
    pub poisson_ratio: f64,
}

/// The settable constants of a contact: its law constants (those of a contact group pair, with
/// `max_penetration` always given) and the sizes of its two shapes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactValues {
    /// The law and its constants.
    pub law: LawConstants,
    /// Sphere radius \[m\].
    pub radius: f64,
    /// sphere_sphere: radius of the other sphere \[m\].
    pub other_radius: f64,
    /// sphere_plane: side lengths of the rectangle \[m\].
    pub size: [f64; 2],
    /// sphere_cylinder: cylinder radius \[m\].
    pub cylinder_radius: f64,
    /// sphere_cylinder: length of the patch \[m\].
    pub length: f64,
}

/// The law constants a contact of the scene gives (a declared one, or the template contact of a
/// group pair), with the defaults of the keys it leaves out; `max_penetration` as given (None:
/// the sphere's radius).
pub fn law_constants(c: &ContactSpec) -> LawConstants {
    LawConstants {
        law: c.law,
        restitution: c.restitution,
        exponent: c.exponent.unwrap_or(1.5),
        damping: c.damping.unwrap_or(0.0),
        max_penetration: c.max_penetration,
        min_impact_velocity: c.min_impact_velocity_or_default(),
        stiffness: c.stiffness,
        friction: Friction::from_values(c.friction_or_default()),
        impulse_method: c.impulse_method,
    }
}

/// [`law_constants`] of a declared `[[contact]]`: its `max_penetration` always given (by default
/// its sphere's radius).
pub fn contact_law_constants(c: &ContactSpec) -> LawConstants {
    LawConstants {
        max_penetration: Some(c.max_penetration_or_default()),
        ..law_constants(c)
    }
}

/// [`law_constants`] of the contact group pair `g` of `scene`: those of the `[[contact]]` it
/// stands for (any two of the scene's shapes give the same).
pub fn group_law_constants(scene: &Scene, g: &ContactGroupSpec) -> LawConstants {
    law_constants(&scene.group_pair_contact(g, &g.name, &scene.shape[0], &scene.shape[0]))
}

/// The settable constants of a spring-damper.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpringValues {
    /// Stiffness \[N/m\].
    pub stiffness: f64,
    /// Damping \[N s/m\].
    pub damping: f64,
    /// Free length \[m\].
    pub free_length: f64,
}

/// Every parameter value of a scene, by item (scene order).
#[derive(Debug, Clone, PartialEq)]
pub struct Parameters {
    /// Per material.
    pub materials: Vec<MaterialValues>,
    /// Per body: mass \[kg\].
    pub masses: Vec<f64>,
    /// Per body: principal moments of inertia about the centre of mass \[kg m²\].
    pub inertias: Vec<[f64; 3]>,
    /// Per body: initial centre-of-mass velocity, world frame \[m/s\].
    pub velocities: Vec<[f64; 3]>,
    /// Per body: initial angular velocity, world frame \[rad/s\].
    pub angular_velocities: Vec<[f64; 3]>,
    /// Per spring-damper.
    pub springs: Vec<SpringValues>,
    /// Per contact.
    pub contacts: Vec<ContactValues>,
    /// Per contact group pair.
    pub groups: Vec<LawConstants>,
    /// Solver settings.
    pub solver: SolverSection,
    /// Per input value (a `joint_motion` has three): its value at the start.
    pub input_start: Vec<f64>,
}

impl Parameters {
    /// The scene's own values (its defaults filled in).
    pub fn of_scene(scene: &Scene) -> Parameters {
        Parameters {
            materials: scene
                .material
                .iter()
                .map(|m| MaterialValues {
                    youngs_modulus: m.youngs_modulus,
                    poisson_ratio: m.poisson_ratio,
                })
                .collect(),
            masses: scene.body.iter().map(|b| b.mass).collect(),
            inertias: scene.body.iter().map(|b| b.inertia).collect(),
            velocities: scene.body.iter().map(|b| b.velocity).collect(),
            angular_velocities: scene.body.iter().map(|b| b.angular_velocity).collect(),
            springs: scene
                .spring_damper
                .iter()
                .map(|s| SpringValues {
                    stiffness: s.stiffness,
                    damping: s.damping,
                    free_length: s.free_length_or_default(),
                })
                .collect(),
            contacts: scene
                .contact
                .iter()
                .map(|c| ContactValues {
                    law: contact_law_constants(c),
                    radius: c.radius,
                    other_radius: c.other_radius.unwrap_or(1.0),
                    size: c.size.unwrap_or([1.0, 1.0]),
                    cylinder_radius: c.cylinder_radius.unwrap_or(1.0),
                    length: c.length.unwrap_or(1.0),
                })
                .collect(),
            groups: scene
                .contact_group
                .iter()
                .map(|g| group_law_constants(scene, g))
                .collect(),
            solver: scene.solver.clone(),
            input_start: scene.input_start_values(),
        }
    }

    /// Checks what depends on several values at once (a law's needs: Kelvin-Voigt needs a
    /// stiffness, Flores e > 0, the Hertz family a stiffness or two materials); single values
    /// are checked against their ranges by the variable table. The message names the contact
    /// and the field; when a host's parameter value (`<contact>.law`, `<contact>.restitution`)
    /// makes the combination impossible, it names that parameter and says what to do.
    pub fn check(&self, scene: &Scene, origin: &str) -> Result<(), SceneError> {
        if let Err((field, msg)) = check_max_step(&self.solver) {
            return Err(SceneError::new(origin, "parameter \"solver.max_step\"", field, msg));
        }
        self.check_geometry(scene, origin)?;
        for (g, v) in scene.contact_group.iter().zip(&self.groups) {
            let materials = scene
                .shape
                .iter()
                .filter(|s| g.groups.contains(&s.group))
                .all(|s| s.material.is_some());
            let no_stiffness = |derived: &str| {
                format!(
                    "this FMU has no \"{}.stiffness\" parameter (the scene gives this group pair no stiffness key{derived})",
                    g.name
                )
            };
            let scene_law = (g.law, g.restitution);
            if let Some((field, msg)) =
                law_parameter_error("contact_group", &g.name, scene_law, v, materials, no_stiffness)
            {
                return Err(SceneError::new(origin, item_name("contact_group", &g.name), field, msg));
            }
        }
        for (c, v) in scene.contact.iter().zip(&self.contacts) {
            let materials = c.sphere_material.is_some() && c.material.is_some();
            let calculated = |derived: &str| {
                format!(
                    "\"{}.stiffness\" is a calculated parameter of this FMU (the scene gives this contact no stiffness \
                     key{derived})",
                    c.name
                )
            };
            let scene_law = (c.law, c.restitution);
            if let Some((field, msg)) =
                law_parameter_error("contact", &c.name, scene_law, &v.law, materials, calculated)
            {
                return Err(SceneError::new(origin, item_name("contact", &c.name), field, msg));
            }
        }
        Ok(())
    }

    /// What the scene checks of several numbers at once, for the values a host may set: the
    /// principal moments of a body satisfy the triangle inequality, and an inside cylinder is
    /// larger than its sphere. The message names the parameters.
    fn check_geometry(&self, scene: &Scene, origin: &str) -> Result<(), SceneError> {
        for (b, &[i1, i2, i3]) in scene.body.iter().zip(&self.inertias) {
            if !inertia_is_physical([i1, i2, i3]) {
                return Err(SceneError::new(
                    origin,
                    item_name("body", &b.name),
                    "inertia",
                    format!(
                        "parameters \"{n}.inertia[1]\", \"{n}.inertia[2]\", \"{n}.inertia[3]\" = [{i1}, {i2}, {i3}] \
                         violate the triangle inequality (no physical body has these moments)",
                        n = b.name
                    ),
                ));
            }
        }
        for (c, v) in scene.contact.iter().zip(&self.contacts) {
            if c.kind == ContactType::SphereCylinder && c.side == Side::Inside && v.cylinder_radius <= v.radius {
                return Err(SceneError::new(
                    origin,
                    item_name("contact", &c.name),
                    "cylinder_radius",
                    format!(
                        "parameters \"{n}.cylinder_radius\" = {} and \"{n}.radius\" = {}: the cylinder radius must \
                         exceed the sphere radius for an inside contact",
                        v.cylinder_radius,
                        v.radius,
                        n = c.name
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// What is wrong with the law constants `v` a host set for the declared contact or group pair
/// `name` (a scene item of `kind`, whose law and restitution are `scene_law`; `materials`: every
/// shape it touches has a material): the field to name and the message (None: nothing). A law
/// chosen by parameter that needs a stiffness the scene does not give says why the host cannot
/// give one (`no_stiffness`, told whether the Hertz family derives it from the materials) and
/// which laws would do.
fn law_parameter_error(
    kind: &str,
    name: &str,
    (scene_law, scene_restitution): (Law, f64),
    v: &LawConstants,
    materials: bool,
    no_stiffness: impl Fn(&str) -> String,
) -> Option<(&'static str, String)> {
    let has_stiffness = v.stiffness.is_some();
    let (field, msg) = check_law(v.law, v.restitution, has_stiffness, materials).err()?;
    let law = format!("parameter \"{name}.law\" = {} ({})", v.law as i64, v.law.name());
    Some(match field {
        "stiffness" if v.law != scene_law => {
            let others = Law::ALL
                .iter()
                .filter(|l| check_law(**l, v.restitution, has_stiffness, materials).is_ok())
                .map(|l| format!("{} = {}", l.name(), *l as i64))
                .collect::<Vec<_>>()
                .join(", ");
            let derived = if materials {
                "; it is derived from the materials for the Hertz family"
            } else {
                ""
            };
            (
                "law",
                format!(
                    "{law} needs a contact stiffness, but {}: choose another law ({others}), or add stiffness to \
                     {kind} {name:?} in the scene and export the FMU again",
                    no_stiffness(derived)
                ),
            )
        }
        "restitution" if v.law != scene_law => (
            "law",
            format!(
                "{law} needs a restitution e > 0, but \"{name}.restitution\" = {}: set e > 0 or choose another law",
                v.restitution
            ),
        ),
        "restitution" if v.restitution != scene_restitution => (
            "restitution",
            format!(
                "parameter \"{name}.restitution\" = {}: the {} law needs e > 0",
                v.restitution,
                v.law.name()
            ),
        ),
        _ => (field, msg),
    })
}
