//! What serde cannot check: names that refer to each other, signs, ranges, the rules for names
//! and numbers (docs/scene.md, "Rules for names and numbers"). Every error names the file, the
//! item and the field.

use super::rules::*;
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
            if name == GROUND {
                // (for every item: a material, contact or group pair so named was accepted)
                return Err(SceneError::new(
                    origin,
                    item,
                    "name",
                    "\"ground\" is reserved for the fixed world".to_string(),
                ));
            }
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
        // ... and refused where this type does not use it
        let what = format!("a {} contact", kind_name(c.kind));
        let surface = match c.kind {
            ContactType::SphereSphere => (false, false),
            ContactType::SpherePlane => (true, false),
            ContactType::SphereCylinder => (false, true),
        };
        c.refuse_unused_surface_keys(origin, item, surface, &what)?;
        if c.kind != ContactType::SphereSphere {
            for (f, given) in [
                ("other_center", c.other_center.is_some()),
                ("other_radius", c.other_radius.is_some()),
            ] {
                if given {
                    return Err(err(f, format!("not used by {what}")));
                }
            }
        }
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
