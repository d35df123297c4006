//! Contact groups: shapes declared once per body (`[[shape]]`), the group pairs that touch
//! (`[[contact_group]]`, with the law of their contacts) and the broad phase that finds the
//! pairs within reach (`[broad_phase]`). A group pair stands for one `[[contact]]` per pair of
//! its shapes: [`Scene::group_pair_contact`] writes that contact.

use super::{
    item_name, length, magnitude, quote, validate_law_keys, vector, ContactSpec, ContactType, ImpulseMethod, Law,
    Scene, SceneError, Side, GROUND,
};
use serde::{Deserialize, Serialize};
use std::collections::{HashMap, HashSet};

/// Kind of a group shape.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum ShapeType {
    /// A sphere (`center`, `radius`).
    #[default]
    Sphere,
    /// A finite rectangle (`origin`, `normal`, `u_axis`, `size`).
    Plane,
    /// A cylindrical surface patch (`axis_point`, `axis`, `cylinder_radius`, `length`, `side`,
    /// `theta_range`, `ref_axis`).
    Cylinder,
}

scene_item! {
    [surface_keys]
    /// `[[shape]]`: one contact shape on a body, member of a group. The keys of each type are
    /// those of the `[[contact]]` element that uses it.
    #[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
    #[serde(deny_unknown_fields)]
    pub struct ShapeSpec {
        /// Group name (a `[[contact_group]]` refers to it).
        pub group: String,
        /// Shape type.
        #[serde(rename = "type")]
        pub kind: ShapeType,
        /// Body carrying the shape (`"ground"` for the world).
        pub body: String,
        /// Material (for the Hertz stiffness).
        pub material: Option<String>,
        /// sphere: centre, world frame \[m\] (default: the body's centre of mass).
        #[serde(default, deserialize_with = "crate::scene::exact::option_array")]
        pub center: Option<[f64; 3]>,
        /// sphere: radius \[m\].
        pub radius: Option<f64>,
    }
}

impl ShapeSpec {
    /// A sphere of `radius` at `center` on `body`, in `group`.
    pub fn sphere(group: &str, body: &str, center: [f64; 3], radius: f64) -> ShapeSpec {
        ShapeSpec {
            center: Some(center),
            radius: Some(radius),
            ..ShapeSpec::new(group, ShapeType::Sphere, body)
        }
    }

    /// The shape with every optional key unset.
    pub fn new(group: &str, kind: ShapeType, body: &str) -> ShapeSpec {
        ShapeSpec {
            group: group.to_string(),
            kind,
            body: body.to_string(),
            ..ShapeSpec::default()
        }
    }

    /// Sets the material.
    pub fn material(mut self, name: &str) -> ShapeSpec {
        self.material = Some(name.to_string());
        self
    }
}

scene_item! {
    [law_keys]
    /// `[[contact_group]]`: the spheres of group `groups[0]` touch the shapes of group
    /// `groups[1]` (the same group: its spheres touch each other). The law keys are those of a
    /// `[[contact]]`, for every pair of the two groups.
    #[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
    #[serde(deny_unknown_fields)]
    pub struct ContactGroupSpec {
        /// Name: the prefix of the group pair's FMU variables.
        pub name: String,
        /// The sphere group, then the group of the shapes they touch.
        #[serde(deserialize_with = "crate::scene::exact::array")]
        pub groups: [String; 2],
        /// Force law.
        pub law: Law,
        /// Coefficient of restitution e.
        #[serde(default = "super::default_restitution")]
        pub restitution: f64,
    }
}

impl ContactGroupSpec {
    /// The group pair `name`: spheres of `spheres` on shapes of `others`, every optional key
    /// at its default.
    pub fn new(name: &str, spheres: &str, others: &str, law: Law) -> ContactGroupSpec {
        ContactGroupSpec {
            name: name.to_string(),
            groups: [spheres.to_string(), others.to_string()],
            law,
            restitution: super::default_restitution(),
            stiffness: None,
            damping: None,
            exponent: None,
            max_penetration: None,
            min_impact_velocity: None,
            impulse_method: ImpulseMethod::Exact,
            friction: None,
            static_friction: None,
            stribeck_velocity: None,
            viscous_friction: None,
            stiction_velocity: None,
        }
    }
}

/// Broad-phase algorithms.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum BroadPhaseMethod {
    /// Sweep and prune along x.
    Sweep,
    /// Uniform grid (cells sorted by key).
    #[default]
    Grid,
}

/// `[broad_phase]`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct BroadPhaseSection {
    /// Distance \[m\] within which two shapes become a candidate pair (default: the largest
    /// sphere radius of the groups).
    pub margin: Option<f64>,
    /// Algorithm.
    #[serde(default)]
    pub method: BroadPhaseMethod,
}

impl BroadPhaseSection {
    /// True when nothing is set (the section is then not written).
    pub fn is_default(&self) -> bool {
        *self == BroadPhaseSection::default()
    }
}

/// An item as messages name a shape: `shape 3 (group "balls", body "s2")` (1-based).
pub fn shape_item(k: usize, s: &ShapeSpec) -> String {
    format!("shape {} (group {}, body {})", k + 1, quote(&s.group), quote(&s.body))
}

impl Scene {
    /// The broad-phase margin: given, or the largest sphere radius of the group shapes.
    pub fn broad_phase_margin(&self) -> f64 {
        self.broad_phase.margin.unwrap_or_else(|| {
            self.shape
                .iter()
                .filter_map(|s| (s.kind == ShapeType::Sphere).then_some(s.radius.unwrap_or(0.0)))
                .fold(0.0, f64::max)
        })
    }

    /// The `[[contact]]` that group pair `g` stands for between sphere shape `a` and shape
    /// `b` (named `name`); the sphere's default centre is its body's position.
    pub fn group_pair_contact(&self, g: &ContactGroupSpec, name: &str, a: &ShapeSpec, b: &ShapeSpec) -> ContactSpec {
        let body_pos = |s: &ShapeSpec| {
            self.body
                .iter()
                .find(|x| x.name == s.body)
                .map_or([0.0; 3], |x| x.position)
        };
        let kind = match b.kind {
            ShapeType::Sphere => ContactType::SphereSphere,
            ShapeType::Plane => ContactType::SpherePlane,
            ShapeType::Cylinder => ContactType::SphereCylinder,
        };
        let mut c = ContactSpec::new(
            name,
            kind,
            g.law,
            &a.body,
            a.center.unwrap_or_else(|| body_pos(a)),
            a.radius.unwrap_or(1.0),
            &b.body,
        );
        c.restitution = g.restitution;
        c.sphere_material = a.material.clone();
        c.material = b.material.clone();
        if kind == ContactType::SphereSphere {
            c.other_center = Some(b.center.unwrap_or_else(|| body_pos(b)));
            c.other_radius = b.radius;
        }
        c.origin = b.origin;
        c.normal = b.normal;
        c.u_axis = b.u_axis;
        c.size = b.size;
        c.axis_point = b.axis_point;
        c.axis = b.axis;
        c.cylinder_radius = b.cylinder_radius;
        c.length = b.length;
        c.theta_range = b.theta_range;
        c.ref_axis = b.ref_axis;
        c.side = b.side;
        c.stiffness = g.stiffness;
        c.damping = g.damping;
        c.exponent = g.exponent;
        c.max_penetration = g.max_penetration;
        c.min_impact_velocity = g.min_impact_velocity;
        c.impulse_method = g.impulse_method;
        c.friction = g.friction;
        c.static_friction = g.static_friction;
        c.stribeck_velocity = g.stribeck_velocity;
        c.viscous_friction = g.viscous_friction;
        c.stiction_velocity = g.stiction_velocity;
        c
    }

    /// The `[[contact]]` list the contact groups stand for: one contact per pair of shapes
    /// whose groups touch (not on one body), named `<pair>_<sphere>_<other>` (1-based shape
    /// numbers), in the order of the group contacts of a model (group pair, sphere shape,
    /// other shape).
    pub fn group_contacts(&self) -> Vec<ContactSpec> {
        let mut out = Vec::new();
        for g in &self.contact_group {
            let [a, b] = &g.groups;
            for (i, s) in self.shape.iter().enumerate() {
                if s.group != *a {
                    continue;
                }
                for (j, o) in self.shape.iter().enumerate() {
                    if o.group != *b || o.body == s.body || (a == b && j <= i) {
                        continue;
                    }
                    let name = format!("{}_{}_{}", g.name, i + 1, j + 1);
                    out.push(self.group_pair_contact(g, &name, s, o));
                }
            }
        }
        out
    }

    /// Checks `[[shape]]`, `[[contact_group]]` and `[broad_phase]` (names are checked for
    /// uniqueness by the caller).
    pub(super) fn validate_groups(
        &self,
        origin: &str,
        bodies: &HashSet<&str>,
        materials: &HashSet<&str>,
    ) -> Result<(), SceneError> {
        let mut groups: HashMap<&str, (bool, bool)> = HashMap::new(); // (all spheres, all with material)
        for (k, s) in self.shape.iter().enumerate() {
            let item = shape_item(k, s);
            let err = |field: &str, msg: String| SceneError::new(origin, &item, field, msg);
            super::check_name(origin, &item, &s.group).map_err(|e| SceneError {
                field: "group".into(),
                ..e
            })?;
            if s.body != GROUND && !bodies.contains(s.body.as_str()) {
                return Err(err("body", format!("unknown body {}", quote(&s.body))));
            }
            if let Some(m) = &s.material {
                if !materials.contains(m.as_str()) {
                    return Err(err("material", format!("unknown material {}", quote(m))));
                }
            }
            let need = |f: &str, present: bool| -> Result<(), SceneError> {
                if present {
                    Ok(())
                } else {
                    Err(err(f, format!("required for a {} shape", kind_word(s.kind))))
                }
            };
            if let Some(center) = s.center {
                vector(origin, &item, "center", &center)?;
            }
            if let Some(radius) = s.radius {
                length(origin, &item, "radius", radius)?;
            }
            s.check_surface_keys(origin, &item)?;
            let (surface, what) = match s.kind {
                ShapeType::Sphere => ((false, false), "a sphere shape"),
                ShapeType::Plane => ((true, false), "a plane shape"),
                ShapeType::Cylinder => ((false, true), "a cylinder shape"),
            };
            s.refuse_unused_surface_keys(origin, &item, surface, what)?;
            if s.kind != ShapeType::Sphere {
                for (f, given) in [("center", s.center.is_some()), ("radius", s.radius.is_some())] {
                    if given {
                        return Err(SceneError::new(origin, &item, f, format!("not used by {what}")));
                    }
                }
            }
            match s.kind {
                ShapeType::Sphere => {
                    need("radius", s.radius.is_some())?;
                    need("center", s.center.is_some() || s.body != GROUND)?;
                }
                ShapeType::Plane => s.check_plane(origin, &item, need)?,
                ShapeType::Cylinder => s.check_cylinder(origin, &item, need)?,
            }
            let e = groups.entry(s.group.as_str()).or_insert((true, true));
            e.0 &= s.kind == ShapeType::Sphere;
            e.1 &= s.material.is_some();
        }
        let mut declared: HashMap<(&str, &str), &str> = HashMap::new();
        for g in &self.contact_group {
            let item = item_name("contact_group", &g.name);
            let err = |field: &str, msg: String| SceneError::new(origin, &item, field, msg);
            let [a, b] = [g.groups[0].as_str(), g.groups[1].as_str()];
            for n in [a, b] {
                if !groups.contains_key(n) {
                    let known: Vec<String> = {
                        let mut k: Vec<&str> = groups.keys().copied().collect();
                        k.sort_unstable();
                        k.into_iter().map(quote).collect()
                    };
                    return Err(err(
                        "groups",
                        format!(
                            "unknown group {} (no [[shape]] names it; groups: {})",
                            quote(n),
                            if known.is_empty() {
                                "none".into()
                            } else {
                                known.join(", ")
                            }
                        ),
                    ));
                }
            }
            if !groups[a].0 {
                return Err(err(
                    "groups",
                    format!(
                        "the first group, {}, holds the spheres of the pair but has other shapes",
                        quote(a)
                    ),
                ));
            }
            for key in [(a, b), (b, a)] {
                if let Some(other) = declared.get(&key) {
                    return Err(err(
                        "groups",
                        format!(
                            "groups {} and {} already touch through contact_group {}",
                            quote(a),
                            quote(b),
                            quote(other)
                        ),
                    ));
                }
            }
            declared.insert((a, b), &g.name);
            // the geometry of each pair, checked as a `[[contact]]`'s is: an inside cylinder
            // must be larger than every sphere it may hold (those on other bodies: shapes on
            // one body never touch)
            for (k, s) in self.shape.iter().enumerate().filter(|(_, s)| s.group == b) {
                let (ShapeType::Cylinder, Side::Inside, Some(rc)) = (s.kind, s.side, s.cylinder_radius) else {
                    continue;
                };
                let largest_sphere = (self.shape.iter().enumerate())
                    .filter(|(_, sp)| sp.group == a && sp.body != s.body)
                    .filter_map(|(ks, sp)| Some((ks, sp.radius?)))
                    .reduce(|x, y| if y.1 > x.1 { y } else { x });
                if let Some((ks, r)) = largest_sphere.filter(|&(_, r)| rc <= r) {
                    return Err(err(
                        "groups",
                        format!(
                            "{} is an inside cylinder of cylinder_radius {rc} m, no larger than the sphere of {} \
                             (radius {r} m): an inside cylinder must exceed the sphere radius",
                            shape_item(k, s),
                            shape_item(ks, &self.shape[ks]),
                        ),
                    ));
                }
            }
            let materials = groups[a].1 && groups[b].1;
            // the law keys, checked on the contact the pair stands for
            let template = ShapeSpec::sphere(a, GROUND, [0.0; 3], 1.0);
            let c = self.group_pair_contact(g, &g.name, &template, &template);
            validate_law_keys(origin, &item, &c, materials).map_err(|e| match e.field.as_str() {
                "stiffness" if !materials => SceneError {
                    message: "give stiffness, or a material on every shape of both groups to derive it".into(),
                    ..e
                },
                _ => e,
            })?;
        }
        if let Some(m) = self.broad_phase.margin {
            if !(m > 0.0 && m.is_finite()) {
                return Err(SceneError::new(
                    origin,
                    "[broad_phase]",
                    "margin",
                    format!("must be > 0 (got {m})"),
                ));
            }
            magnitude(origin, "[broad_phase]", "margin", m)?;
        }
        Ok(())
    }
}

fn kind_word(k: ShapeType) -> &'static str {
    match k {
        ShapeType::Sphere => "sphere",
        ShapeType::Plane => "plane",
        ShapeType::Cylinder => "cylinder",
    }
}
