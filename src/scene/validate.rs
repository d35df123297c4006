//! What serde cannot check: names that refer to each other, signs, ranges, the rules for names
//! and numbers (docs/scene.md, "Rules for names and numbers"). Every error names the file, the
//! item and the field.

use super::*;

impl Scene {
    /// Parses a scene from TOML text; `origin` names the file in messages. Also validates.
    pub fn from_str(text: &str, origin: &str) -> Result<Scene, SceneError> {
        let scene: Scene = toml::from_str(text).map_err(|e| {
            let (line, col) = e.span().map(|s| line_col(text, s.start)).unwrap_or((0, 0));
            SceneError::new(
                origin,
                format!("line {line}, column {col}"),
                "toml",
                // one line: the parser's message may span several
                e.message()
                    .lines()
                    .map(str::trim)
                    .filter(|l| !l.is_empty())
                    .collect::<Vec<_>>()
                    .join("; "),
            )
        })?;
        scene.validate(origin)?;
        Ok(scene)
    }

    /// Reads and parses a scene file.
    pub fn from_file(path: &Path) -> Result<Scene, SceneError> {
        let origin = path.display().to_string();
        let text = std::fs::read_to_string(path)
            .map_err(|e| SceneError::new(&origin, "file", "-", format!("cannot read: {e}")))?;
        Scene::from_str(&text, &origin)
    }

    /// Checks names, references, signs, ranges and magnitudes (the rules of docs/scene.md,
    /// "Rules for names and numbers"). Geometry-level checks that need the compiled tree
    /// (cycles, loops) are done by the model compiler.
    pub fn validate(&self, origin: &str) -> Result<(), SceneError> {
        let err = |item: String, field: &str, msg: String| SceneError::new(origin, item, field, msg);
        let m = &self.model;
        check_model_name(origin, &m.name)?;
        check_text(origin, "[model]", "description", &m.description)?;
        vector(origin, "[model]", "gravity", &m.gravity)?;
        positive(origin, "[model]", "stop_time", m.stop_time)?;
        positive(origin, "[model]", "interval", m.interval)?;
        let points = m.stop_time / m.interval;
        if points > MAX_COMMUNICATION_POINTS {
            return Err(err(
                "[model]".into(),
                "interval",
                format!(
                    "{} gives {points:.3e} communication points up to stop_time = {}; at most {MAX_COMMUNICATION_POINTS:e}",
                    short(m.interval),
                    short(m.stop_time)
                ),
            ));
        }
        let s = &self.solver;
        for (f, v, [lo, hi], why) in [
            (
                "rtol",
                s.rtol,
                RTOL_RANGE,
                "a looser tolerance gives results without meaning (the energy drifts), a tighter one \
                 lies below the rounding error",
            ),
            (
                "atol",
                s.atol,
                ATOL_RANGE,
                "a looser tolerance gives results without meaning, a much tighter one makes steps \
                 fail on components near zero",
            ),
        ] {
            if !(v >= lo && v <= hi) {
                return Err(err(
                    "[solver]".into(),
                    f,
                    format!("must be in [{}, {}] (got {}): {why}", short(lo), short(hi), short(v)),
                ));
            }
        }
        if !(1..=MAX_STEPS_LIMIT).contains(&s.max_steps) {
            return Err(err(
                "[solver]".into(),
                "max_steps",
                format!(
                    "must be in [1, {MAX_STEPS_LIMIT}] (got {}): the steps one communication step may take",
                    s.max_steps
                ),
            ));
        }
        if let Err((field, msg)) = check_max_step(s) {
            return Err(err("[solver]".into(), field, msg));
        }
        if s.threads > MAX_THREADS {
            return Err(err(
                "[solver]".into(),
                "threads",
                format!(
                    "must be at most {MAX_THREADS} (got {}; 0 takes as many as the machine has)",
                    s.threads
                ),
            ));
        }
        // every name is valid and unique across the scene
        let mut names: HashSet<&str> = HashSet::new();
        let mut unique = |item: &str, name| -> Result<(), SceneError> {
            check_name(origin, item, name)?;
            if RESERVED_NAMES.contains(&name) {
                return Err(SceneError::new(
                    origin,
                    item,
                    "name",
                    format!(
                        "{} is reserved for the FMU's own variables (time, solver.*, energy.*)",
                        quote(name)
                    ),
                ));
            }
            if !names.insert(name) {
                return Err(SceneError::new(
                    origin,
                    item,
                    "name",
                    format!("duplicate name {}", quote(name)),
                ));
            }
            Ok(())
        };
        let mut materials = HashSet::new();
        for mat in &self.material {
            let item = item_name("material", &mat.name);
            unique(&item, &mat.name)?;
            materials.insert(mat.name.as_str());
            positive(origin, &item, "youngs_modulus", mat.youngs_modulus)?;
            if !(mat.poisson_ratio >= 0.0 && mat.poisson_ratio < 0.5) {
                return Err(err(
                    item,
                    "poisson_ratio",
                    format!("must be in [0, 0.5) (got {})", mat.poisson_ratio),
                ));
            }
        }
        let mut bodies = HashSet::new();
        for b in &self.body {
            let item = item_name("body", &b.name);
            if b.name == GROUND {
                return Err(err(item, "name", "\"ground\" is reserved for the fixed world".into()));
            }
            unique(&item, &b.name)?;
            bodies.insert(b.name.as_str());
            positive(origin, &item, "mass", b.mass)?;
            let [a, bb, c] = b.inertia;
            if !(a > 0.0 && bb > 0.0 && c > 0.0 && a.is_finite() && bb.is_finite() && c.is_finite()) {
                return Err(err(
                    item,
                    "inertia",
                    "principal moments must be > 0 (positive definite)".into(),
                ));
            }
            if !inertia_is_physical(b.inertia) {
                return Err(err(
                    item,
                    "inertia",
                    "violates the triangle inequality (no physical body has these moments)".into(),
                ));
            }
            vector(origin, &item, "position", &b.position)?;
            vector(origin, &item, "velocity", &b.velocity)?;
            vector(origin, &item, "angular_velocity", &b.angular_velocity)?;
            for (field, v) in [("velocity", b.velocity), ("angular_velocity", b.angular_velocity)] {
                let speed = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                if speed > RUNAWAY_SPEED {
                    return Err(err(
                        item.clone(),
                        field,
                        format!(
                            "a speed of {} is beyond {RUNAWAY_SPEED:e}, which no rigid mechanism reaches (the run would stop at once as blown up)",
                            short(speed)
                        ),
                    ));
                }
            }
            let q = b.orientation;
            let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
            if !(n.is_finite() && (n - 1.0).abs() < 1e-6) {
                return Err(err(
                    item,
                    "orientation",
                    format!("must be a unit quaternion (norm {n})"),
                ));
            }
        }
        let is_body = |n: &str| n == GROUND || bodies.contains(n);
        let mut joints = HashMap::new();
        for j in &self.joint {
            let item = item_name("joint", &j.name);
            unique(&item, &j.name)?;
            joints.insert(j.name.as_str(), j);
            if !is_body(&j.parent) {
                return Err(err(item, "parent", format!("unknown body {}", quote(&j.parent))));
            }
            if !bodies.contains(j.child.as_str()) {
                return Err(err(
                    item,
                    "child",
                    format!("unknown body {} (the ground cannot be a child)", quote(&j.child)),
                ));
            }
            if j.parent == j.child {
                return Err(err(item, "child", "a body cannot be joined to itself".into()));
            }
            if let Some(a) = j.anchor {
                vector(origin, &item, "anchor", &a)?;
            }
            match (j.kind, j.axis) {
                // a fixed or spherical joint that closes a loop uses a given axis too
                (_, Some(ax)) => direction(origin, &item, "axis", ax)?,
                (JointType::Revolute | JointType::Prismatic, None) => {
                    return Err(err(item, "axis", "required for revolute and prismatic joints".into()));
                }
                _ => {}
            }
        }
        for s in &self.spring_damper {
            let item = item_name("spring_damper", &s.name);
            unique(&item, &s.name)?;
            if !is_body(&s.body_a) {
                return Err(err(item, "body_a", format!("unknown body {}", quote(&s.body_a))));
            }
            if !is_body(&s.body_b) {
                return Err(err(item, "body_b", format!("unknown body {}", quote(&s.body_b))));
            }
            if s.body_a == s.body_b {
                return Err(err(item, "body_b", "must differ from body_a".into()));
            }
            vector(origin, &item, "point_a", &s.point_a)?;
            vector(origin, &item, "point_b", &s.point_b)?;
            nonnegative(origin, &item, "stiffness", s.stiffness)?;
            nonnegative(origin, &item, "damping", s.damping)?;
            if let Some(l) = s.free_length {
                nonnegative(origin, &item, "free_length", l)?;
                magnitude(origin, &item, "free_length", l)?;
            }
        }
        for c in &self.contact {
            let item = item_name("contact", &c.name);
            unique(&item, &c.name)?;
            self.validate_contact(origin, &item, c, &bodies, &materials)?;
        }
        for g in &self.contact_group {
            unique(&item_name("contact_group", &g.name), &g.name)?;
        }
        self.validate_groups(origin, &bodies, &materials)?;
        for i in &self.input {
            let item = item_name("input", &i.name);
            unique(&item, &i.name)?;
            // (the first given of two fields the input's type does not use is refused)
            let unused = |given: [(&str, bool); 2], why: &str| match given.iter().find(|(_, g)| *g) {
                Some((field, _)) => Err(err(item.clone(), field, why.into())),
                None => Ok(()),
            };
            if let Some(d) = i.direction {
                direction(origin, &item, "direction", d)?;
            }
            match i.kind {
                InputType::Force | InputType::Torque => {
                    let Some(b) = &i.body else {
                        return Err(err(item, "body", "required for force and torque inputs".into()));
                    };
                    if !bodies.contains(b.as_str()) {
                        return Err(err(item, "body", format!("unknown body {}", quote(b))));
                    }
                    if i.direction.is_none() {
                        return Err(err(item, "direction", "required for force and torque inputs".into()));
                    }
                    unused(
                        [("joint", i.joint.is_some()), ("joints", i.joints.is_some())],
                        "not used by a force or torque input (it acts on its body)",
                    )?;
                }
                InputType::JointMotion => {
                    if i.joints.is_some() {
                        return Err(err(
                            item,
                            "joints",
                            "a joint_motion drives one joint: give joint".into(),
                        ));
                    }
                    let Some(jn) = &i.joint else {
                        return Err(err(item, "joint", "required for joint_motion inputs".into()));
                    };
                    let Some(j) = joints.get(jn.as_str()) else {
                        return Err(err(item, "joint", format!("unknown joint {}", quote(jn))));
                    };
                    if !matches!(j.kind, JointType::Revolute | JointType::Prismatic) {
                        return Err(err(
                            item,
                            "joint",
                            format!(
                                "joint {} is not a 1-DOF joint (a joint_motion drives a revolute or prismatic joint)",
                                quote(jn)
                            ),
                        ));
                    }
                    if let Some(other) = self
                        .input
                        .iter()
                        .take_while(|o| !std::ptr::eq(*o, i))
                        .find(|o| o.kind == InputType::JointMotion && o.joint.as_deref() == Some(jn.as_str()))
                    {
                        return Err(err(
                            item,
                            "joint",
                            format!("joint {} is already driven by input {}", quote(jn), quote(&other.name)),
                        ));
                    }
                    unused(
                        [("body", i.body.is_some()), ("direction", i.direction.is_some())],
                        "not used by a joint_motion input (it drives its joint)",
                    )?;
                    if i.start != 0.0 {
                        return Err(err(
                            item,
                            "start",
                            "a joint_motion starts at the joint's initial coordinate and rate (set <input>.q and \
                             <input>.qd to change them)"
                                .into(),
                        ));
                    }
                }
                InputType::JointForce => {
                    let names: Vec<&String> = match (&i.joint, &i.joints) {
                        (Some(j), None) => vec![j],
                        (None, Some(js)) if !js.is_empty() => js.iter().collect(),
                        (Some(_), Some(_)) => {
                            return Err(err(item, "joints", "give joint or joints, not both".into()));
                        }
                        _ => return Err(err(item, "joint", "required for joint_force inputs (or joints)".into())),
                    };
                    unused(
                        [("body", i.body.is_some()), ("direction", i.direction.is_some())],
                        "not used by a joint_force input (it acts on its joints)",
                    )?;
                    let field = if i.joint.is_some() { "joint" } else { "joints" };
                    let mut kinds = names.iter().filter_map(|n| joints.get(n.as_str()).map(|j| j.kind));
                    if let Some(first) = kinds.next() {
                        if kinds.any(|k| k != first) {
                            return Err(err(
                                item,
                                field,
                                "mixes revolute and prismatic joints (a torque and a force in one input)".into(),
                            ));
                        }
                    }
                    let mut seen = HashSet::new();
                    for jn in names {
                        let Some(j) = joints.get(jn.as_str()) else {
                            return Err(err(item, field, format!("unknown joint {}", quote(jn))));
                        };
                        if !seen.insert(jn.as_str()) {
                            return Err(err(
                                item,
                                field,
                                format!("names joint {} twice (it would take the force twice)", quote(jn)),
                            ));
                        }
                        if !matches!(j.kind, JointType::Revolute | JointType::Prismatic) {
                            return Err(err(item, field, format!("joint {} is not a 1-DOF joint", quote(jn))));
                        }
                    }
                }
            }
            if !i.start.is_finite() {
                return Err(err(item, "start", format!("must be finite (got {})", i.start)));
            }
        }
        Ok(())
    }

    fn validate_contact(
        &self,
        origin: &str,
        item: &str,
        c: &ContactSpec,
        bodies: &HashSet<&str>,
        materials: &HashSet<&str>,
    ) -> Result<(), SceneError> {
        let err = |field: &str, msg: String| SceneError::new(origin, item, field, msg);
        let is_body = |n: &str| n == GROUND || bodies.contains(n);
        if !is_body(&c.sphere_body) {
            return Err(err("sphere_body", format!("unknown body {}", quote(&c.sphere_body))));
        }
        if !is_body(&c.body) {
            return Err(err("body", format!("unknown body {}", quote(&c.body))));
        }
        if c.sphere_body == GROUND && c.body == GROUND {
            return Err(err(
                "body",
                "both shapes are on the ground: this contact can never act".into(),
            ));
        }
        if c.sphere_body == c.body {
            return Err(err("body", "both shapes are on the same body".into()));
        }
        if !(0.0..=1.0).contains(&c.restitution) {
            return Err(err("restitution", format!("must be in [0, 1] (got {})", c.restitution)));
        }
        length(origin, item, "radius", c.radius)?;
        if c.max_penetration.is_none() && c.radius < MIN_MAX_PENETRATION {
            return Err(err(
                "radius",
                format!(
                    "{} m is below {MIN_MAX_PENETRATION:e} m, the least max_penetration, which defaults to the radius: give max_penetration",
                    short(c.radius)
                ),
            ));
        }
        vector(origin, item, "center", &c.center)?;
        for (f, m) in [("sphere_material", &c.sphere_material), ("material", &c.material)] {
            if let Some(m) = m {
                if !materials.contains(m.as_str()) {
                    return Err(err(f, format!("unknown material {}", quote(m))));
                }
            }
        }
        // Every number given is checked, whether or not this type of contact uses it.
        if let Some(v) = c.other_center {
            vector(origin, item, "other_center", &v)?;
        }
        if let Some(v) = c.other_radius {
            length(origin, item, "other_radius", v)?;
        }
        c.check_surface_keys(origin, item)?;
        let need = |f: &str, present: bool| -> Result<(), SceneError> {
            if present {
                Ok(())
            } else {
                Err(err(f, format!("required for a {} contact", kind_name(c.kind))))
            }
        };
        match c.kind {
            ContactType::SphereSphere => {
                need("other_center", c.other_center.is_some())?;
                need("other_radius", c.other_radius.is_some())?;
            }
            ContactType::SpherePlane => c.check_plane(origin, item, need)?,
            ContactType::SphereCylinder => {
                c.check_cylinder(origin, item, need)?;
                if c.side == Side::Inside && c.cylinder_radius.unwrap_or(0.0) <= c.radius {
                    return Err(err(
                        "cylinder_radius",
                        "must exceed the sphere radius for an inside contact".into(),
                    ));
                }
            }
        }
        let materials = c.sphere_material.is_some() && c.material.is_some();
        validate_law_keys(origin, item, c, materials)
    }
}

/// The side lengths and the angular range of a surface (`[[contact]]` or `[[shape]]`), where
/// given: finite, positive and ordered, and within the largest magnitude.
pub(super) fn surface_extent(
    origin: &str,
    item: &str,
    size: Option<[f64; 2]>,
    theta_range: Option<[f64; 2]>,
) -> Result<(), SceneError> {
    let err = |field: &str, msg: String| SceneError::new(origin, item, field, msg);
    if let Some([a, b]) = size {
        if !(a > 0.0 && b > 0.0 && a.is_finite() && b.is_finite()) {
            return Err(err(
                "size",
                format!("both side lengths must be finite and > 0 (got [{a}, {b}])"),
            ));
        }
        magnitude(origin, item, "size", a.max(b))?;
    }
    if let Some([a, b]) = theta_range {
        if !(a.is_finite() && b.is_finite()) || a >= b {
            return Err(err("theta_range", "needs finite min < max".into()));
        }
        magnitude(origin, item, "theta_range", a.abs().max(b.abs()))?;
    }
    Ok(())
}

/// The direction `field` (`v`) perpendicular to the direction `other` (`w`), where both are
/// given (an absent one counts as zero).
pub(super) fn perpendicular(
    (origin, item): (&str, &str),
    (field, v): (&str, Option<[f64; 3]>),
    (other, w): (&str, Option<[f64; 3]>),
) -> Result<(), SceneError> {
    let (w, v) = (unit(w.unwrap_or_default()), unit(v.unwrap_or_default()));
    if (w[0] * v[0] + w[1] * v[1] + w[2] * v[2]).abs() > 1e-6 {
        return Err(SceneError::new(
            origin,
            item,
            field,
            format!("must be perpendicular to {other}"),
        ));
    }
    Ok(())
}

/// The law constants of a contact (or of a contact group's template contact): what
/// [`check_law`] asks, signs and ranges of the optional keys.
pub(super) fn validate_law_keys(origin: &str, item: &str, c: &ContactSpec, materials: bool) -> Result<(), SceneError> {
    let err = |field: &str, msg: String| SceneError::new(origin, item, field, msg);
    {
        if !(0.0..=1.0).contains(&c.restitution) {
            return Err(err("restitution", format!("must be in [0, 1] (got {})", c.restitution)));
        }
        check_law(c.law, c.restitution, c.stiffness.is_some(), materials).map_err(|(f, m)| err(f, m))?;
        if let Some(k) = c.stiffness {
            positive(origin, item, "stiffness", k)?;
        }
        if let Some(v) = c.max_penetration {
            if !(v > 0.0 && v.is_finite()) {
                return Err(err(
                    "max_penetration",
                    format!("must be > 0 (got {v}): no penetration could be admitted"),
                ));
            }
            if v < MIN_MAX_PENETRATION {
                return Err(err(
                    "max_penetration",
                    format!(
                        "must be at least {MIN_MAX_PENETRATION:e} m (got {}): a step could pass through so thin a band of admitted penetrations unseen, and the sphere through the surface",
                        short(v)
                    ),
                ));
            }
            magnitude(origin, item, "max_penetration", v)?;
        }
        let nonnegative_keys = [
            ("damping", c.damping),
            ("min_impact_velocity", c.min_impact_velocity),
            ("friction", c.friction),
            ("static_friction", c.static_friction),
            ("viscous_friction", c.viscous_friction),
        ];
        each_given(nonnegative_keys, |f, v| nonnegative(origin, item, f, v))?;
        let velocities = [
            ("stribeck_velocity", c.stribeck_velocity),
            ("stiction_velocity", c.stiction_velocity),
        ];
        each_given(velocities, |f, v| {
            positive(origin, item, f, v)?;
            magnitude(origin, item, f, v)
        })?;
        if let Some(n) = c.exponent {
            if !(n >= 1.0 && n.is_finite()) {
                return Err(err("exponent", format!("must be >= 1 (got {n})")));
            }
        }
        Ok(())
    }
}

/// `solver.threads` is at most this many.
pub const MAX_THREADS: usize = 256;

/// `solver.rtol` must lie in this range (closed): looser tolerances give results without
/// meaning (at 3e-2 the bundled bouncing ball gains 19× its energy, at 0.5 5.5×), tighter
/// ones lie below the rounding error of f64. The FMU parameter has the same range.
pub const RTOL_RANGE: [f64; 2] = [1e-14, 1e-2];

/// `solver.atol` must lie in this range (closed): it is absolute, in the units of the state
/// (m, rad, m/s, rad/s, J), so above 1e-2 the error control stops seeing the motion; small
/// motions need small values (1e-17 for oscillations of 1e-4 rad), but far below 1e-20 steps
/// fail on components that stay near zero (at 1e-30 the bundled slider-crank fails). The FMU
/// parameter has the same range.
pub const ATOL_RANGE: [f64; 2] = [1e-20, 1e-2];

/// `solver.max_step`: 0 (none; `rk4` then steps by [`RK4_DEFAULT_STEP`]) or at least
/// [`MIN_MAX_STEP`], finite. Returns the field and the message.
pub fn check_max_step(s: &SolverSection) -> Result<(), (&'static str, String)> {
    let h = s.max_step;
    if !(h == 0.0 || (h >= MIN_MAX_STEP && h.is_finite())) {
        return Err((
            "max_step",
            format!(
                "must be 0 (none) or finite and >= {MIN_MAX_STEP:e} s (got {}): a smaller step never ends a simulation",
                short(h)
            ),
        ));
    }
    Ok(())
}

/// The fixed step of `rk4` \[s\] when `solver.max_step` is 0 (none).
pub const RK4_DEFAULT_STEP: f64 = 1e-3;

/// Smallest `solver.max_step` \[s\]: the step of `rk4`, and a cap on every method's step;
/// a smaller one makes any simulation practically endless (and below the rounding of the
/// time, truly endless). The FMU parameter has the same lower bound.
pub const MIN_MAX_STEP: f64 = 1e-9;

/// Largest magnitude of a coordinate \[m\], a length \[m\], a vector component (directions,
/// velocities, gravity) or an angle \[rad\] in a scene: the model forms squares and products
/// of them, which overflow or lose all precision beyond this.
pub const MAX_MAGNITUDE: f64 = 1e12;

/// A speed no rigid mechanism reaches \[m/s or rad/s\]: the engine takes a velocity coordinate
/// beyond it for an integration that blew up (before the kinetic energy overflows), so an
/// initial velocity may not reach it.
pub const RUNAWAY_SPEED: f64 = 1e8;

/// Names no item may take: the FMU's own variables are `time` (FMI 3.0's independent
/// variable), `solver.*` and `energy.*` (an input named `time` made a second variable of that
/// name, one named `solver` or `energy` a variable beside the structured names under it).
pub const RESERVED_NAMES: [&str; 3] = ["time", "solver", "energy"];

/// The most `solver.max_steps` (the range of an FMI Integer).
pub const MAX_STEPS_LIMIT: u64 = i32::MAX as u64;

/// The least `max_penetration` \[m\]: a contact acts while `0 < δ < max_penetration`, and a
/// band much thinner than this (1e-17 m and below, near the rounding of positions of a metre)
/// could be stepped across unseen (a ball fell through the floor without an error).
pub const MIN_MAX_PENETRATION: f64 = 1e-9;

/// Most communication points of the default experiment (`stop_time / interval`).
pub const MAX_COMMUNICATION_POINTS: f64 = 1e9;

/// Longest model name: the FMU's file name (`<name>.fmu`, `<name>.so`) and
/// `modelIdentifier`, with room for suffixes within the 255 bytes of a file name.
pub const MAX_MODEL_NAME: usize = 200;

/// Names that Windows reserves for devices, refused as model names (`NUL.fmu` cannot be a
/// file there), compared without case.
pub(super) const DEVICE_NAMES: [&str; 22] = [
    "con", "prn", "aux", "nul", "com1", "com2", "com3", "com4", "com5", "com6", "com7", "com8", "com9", "lpt1", "lpt2",
    "lpt3", "lpt4", "lpt5", "lpt6", "lpt7", "lpt8", "lpt9",
];

/// A number as messages show it: the shorter of plain and scientific notation (`0.5`, `1e-15`).
pub fn short(x: f64) -> String {
    let (plain, sci) = (format!("{x}"), format!("{x:e}"));
    if sci.len() < plain.len() {
        sci
    } else {
        plain
    }
}

/// A name as messages show it: quoted and escaped (`"arm"`, `"a\tb"`), a long one cut to its
/// first 40 characters.
pub fn quote(name: &str) -> String {
    const SHOWN: usize = 40;
    let n = name.chars().count();
    if n <= SHOWN {
        format!("{name:?}")
    } else {
        let head: String = name.chars().take(SHOWN).collect();
        format!("{head:?}… ({n} characters)")
    }
}

/// An item as messages name it: its kind and its quoted name, e.g. `body "arm"`.
pub fn item_name(kind: &str, name: &str) -> String {
    format!("{kind} {}", quote(name))
}

/// A character that XML 1.0 cannot carry (U+FFFE, U+FFFF) or a control character (C0,
/// DEL, C1; tab and line breaks included: an XML attribute would turn them into spaces).
pub(super) fn is_forbidden_char(c: char) -> bool {
    c.is_control() || c == '\u{FFFE}' || c == '\u{FFFF}'
}

/// A character in words, for messages: `a tab (U+0009)`, `'%' (U+0025)`.
pub(super) fn describe_char(c: char) -> String {
    let code = format!("U+{:04X}", c as u32);
    match c {
        '\t' => format!("a tab ({code})"),
        '\n' => format!("a line feed ({code})"),
        '\r' => format!("a carriage return ({code})"),
        ' ' => format!("a space ({code})"),
        '\u{FFFE}' | '\u{FFFF}' => format!("the non-character {code} (XML cannot carry it)"),
        c if c.is_control() => format!("the control character {code}"),
        c => format!("{c:?} ({code})"),
    }
}

/// A name of a material, body, joint, spring-damper, contact or input: it becomes (the first
/// part of) FMU variable names, whose structured form (`arm.mass`, `arm.r[1]`) allows, unquoted,
/// only a letter or `_` followed by letters, digits and `_` (the FMI 2.0 grammar that fmpy
/// checks).
pub(super) fn check_name(origin: &str, item: &str, name: &str) -> Result<(), SceneError> {
    let rule = "a name is a letter or '_' followed by letters, digits and '_' \
                (it becomes part of FMU variable names such as \"arm.mass\")";
    let bad = |what: String| SceneError::new(origin, item, "name", format!("{} {what}; {rule}", quote(name)));
    if name.is_empty() {
        return Err(SceneError::new(
            origin,
            item,
            "name",
            format!("must not be empty; {rule}"),
        ));
    }
    if let Some(c) = name.chars().find(|c| !(c.is_ascii_alphanumeric() || *c == '_')) {
        return Err(bad(format!("contains {}", describe_char(c))));
    }
    if name.starts_with(|c: char| c.is_ascii_digit()) {
        return Err(bad("starts with a digit".into()));
    }
    Ok(())
}

/// The model name: a C identifier (the FMU's `modelIdentifier`), at most [`MAX_MODEL_NAME`]
/// characters, not a device name (it is also the FMU's file name).
pub(super) fn check_model_name(origin: &str, name: &str) -> Result<(), SceneError> {
    let item = "[model]";
    let rule = "the model name is a C identifier (letters, digits, _; not starting with a digit), \
                the FMU's modelIdentifier and file name";
    let bad = |what: String| SceneError::new(origin, item, "name", format!("{what}; {rule}"));
    if name.is_empty() {
        return Err(bad("must not be empty".into()));
    }
    let n = name.chars().count();
    if n > MAX_MODEL_NAME {
        return Err(bad(format!(
            "{} is {n} characters long, at most {MAX_MODEL_NAME} are allowed",
            quote(name)
        )));
    }
    if let Some(c) = name.chars().find(|c| !(c.is_ascii_alphanumeric() || *c == '_')) {
        return Err(bad(format!("{} contains {}", quote(name), describe_char(c))));
    }
    if name.starts_with(|c: char| c.is_ascii_digit()) {
        return Err(bad(format!("{} starts with a digit", quote(name))));
    }
    if DEVICE_NAMES.iter().any(|d| d.eq_ignore_ascii_case(name)) {
        return Err(bad(format!(
            "{} is a device name on Windows and cannot be a file name there",
            quote(name)
        )));
    }
    Ok(())
}

/// Free text that goes into an XML attribute: no control characters.
pub(super) fn check_text(origin: &str, item: &str, field: &str, text: &str) -> Result<(), SceneError> {
    match text.chars().enumerate().find(|(_, c)| is_forbidden_char(*c)) {
        Some((i, c)) => Err(SceneError::new(
            origin,
            item,
            field,
            format!(
                "character {} is {}; it must be one line of text without control characters",
                i + 1,
                describe_char(c)
            ),
        )),
        None => Ok(()),
    }
}

pub(super) fn kind_name(k: ContactType) -> &'static str {
    match k {
        ContactType::SphereSphere => "sphere_sphere",
        ContactType::SpherePlane => "sphere_plane",
        ContactType::SphereCylinder => "sphere_cylinder",
    }
}

pub(super) fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / n, v[1] / n, v[2] / n]
}

/// Applies `check` to each optional key that is given: `(field, value)`.
pub(super) fn each_given<T, const N: usize>(
    keys: [(&str, Option<T>); N],
    mut check: impl FnMut(&str, T) -> Result<(), SceneError>,
) -> Result<(), SceneError> {
    keys.into_iter()
        .filter_map(|(field, value)| value.map(|v| (field, v)))
        .try_for_each(|(field, v)| check(field, v))
}

/// `|x| <= MAX_MAGNITUDE` (for a finite `x`).
pub(super) fn magnitude(origin: &str, item: &str, field: &str, x: f64) -> Result<(), SceneError> {
    if x.abs() <= MAX_MAGNITUDE {
        Ok(())
    } else {
        Err(SceneError::new(
            origin,
            item,
            field,
            format!(
                "{x:e} is too large: at most {MAX_MAGNITUDE:e} in magnitude (beyond, the model's squares and \
                 products overflow or lose all precision)"
            ),
        ))
    }
}

/// A vector (point, velocity, gravity): finite components of magnitude at most
/// [`MAX_MAGNITUDE`].
pub(super) fn vector(origin: &str, item: &str, field: &str, v: &[f64]) -> Result<(), SceneError> {
    if let Some(x) = v.iter().find(|x| !x.is_finite()) {
        return Err(SceneError::new(
            origin,
            item,
            field,
            format!("must be finite (got a component {x})"),
        ));
    }
    match v.iter().find(|x| x.abs() > MAX_MAGNITUDE) {
        Some(&x) => magnitude(origin, item, field, x),
        None => Ok(()),
    }
}

/// A direction: a [`vector`] of length > 1e-12 (it is normalised).
pub(super) fn direction(origin: &str, item: &str, field: &str, v: [f64; 3]) -> Result<(), SceneError> {
    vector(origin, item, field, &v)?;
    if v.iter().map(|x| x * x).sum::<f64>() > 1e-24 {
        Ok(())
    } else {
        Err(SceneError::new(origin, item, field, "must not be the zero vector"))
    }
}

/// A finite `x > 0`.
pub(super) fn positive(origin: &str, item: &str, field: &str, x: f64) -> Result<(), SceneError> {
    let msg = if !x.is_finite() {
        format!("must be finite (got {x})")
    } else if x > 0.0 {
        return Ok(());
    } else {
        format!("must be > 0 (got {})", short(x))
    };
    Err(SceneError::new(origin, item, field, msg))
}

/// A finite `x >= 0`.
pub(super) fn nonnegative(origin: &str, item: &str, field: &str, x: f64) -> Result<(), SceneError> {
    let msg = if !x.is_finite() {
        format!("must be finite (got {x})")
    } else if x >= 0.0 {
        return Ok(());
    } else {
        format!("must be >= 0 (got {})", short(x))
    };
    Err(SceneError::new(origin, item, field, msg))
}

/// A length \[m\]: finite, > 0, at most [`MAX_MAGNITUDE`].
pub(super) fn length(origin: &str, item: &str, field: &str, x: f64) -> Result<(), SceneError> {
    positive(origin, item, field, x)?;
    magnitude(origin, item, field, x)
}

pub(super) fn line_col(text: &str, byte: usize) -> (usize, usize) {
    let before = &text[..byte.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.len() - before.rfind('\n').map(|i| i + 1).unwrap_or(0) + 1;
    (line, col)
}
