//! The variable table in value-reference order, section by section: the parameters of the
//! materials, bodies and contacts; the solver's; the inputs; the outputs; then the parameters
//! added later, after every variable that was there before them (so that no value reference
//! of an earlier scene moves).

use super::law::{law_value, law_variable, FRICTION_KEYS};
use super::*;

/// The Real parameters `<owner>.<key>[1]` … `[3]` of the triple `values`: component `k` sets
/// `target(k)`.
fn param_triple(
    owner: &str,
    key: &str,
    values: [f64; 3],
    unit: &'static str,
    range: Range,
    target: impl Fn(usize) -> VarRef,
    description: &str,
) -> [Variable; 3] {
    std::array::from_fn(|k| {
        param(
            format!("{owner}.{key}[{}]", k + 1),
            values[k],
            Some(unit),
            range,
            target(k),
            description,
        )
    })
}

/// An output that no input changes at once.
fn out(name: String, vtype: VarType, unit: Option<&'static str>, target: VarRef, description: String) -> Variable {
    output_variable(name, vtype, unit, target, description, false)
}

/// `var` with the display unit a host shows by default.
fn with_display(mut var: Variable, display: &'static str) -> Variable {
    var.display_unit = Some(display);
    var
}

/// Materials, bodies (mass), contacts (law and its constants).
pub(super) fn parameters(scene: &Scene, v: &mut Vec<Variable>) {
    let pos = Range::open_above(0.0, true);
    for (i, m) in scene.material.iter().enumerate() {
        v.push(param(
            format!("{}.youngs_modulus", m.name),
            m.youngs_modulus,
            Some("Pa"),
            pos,
            VarRef::YoungsModulus(i),
            "Young's modulus",
        ));
        v.push(param(
            format!("{}.poisson_ratio", m.name),
            m.poisson_ratio,
            None,
            Range {
                min: 0.0,
                min_exclusive: false,
                max: 0.5,
                max_exclusive: true,
            },
            VarRef::PoissonRatio(i),
            "Poisson's ratio",
        ));
    }
    for (i, b) in scene.body.iter().enumerate() {
        v.push(param(
            format!("{}.mass", b.name),
            b.mass,
            Some("kg"),
            pos,
            VarRef::Mass(i),
            "mass of the body",
        ));
    }
    for (i, c) in scene.contact.iter().enumerate() {
        let law = crate::compile::contact_law_constants(c);
        let t = |key| VarRef::Contact(i, key);
        v.push(enum_param(
            format!("{}.law", c.name),
            EnumType::ContactLaw,
            c.law as i64,
            t(LawKey::Law),
            "contact force law: continuous (kelvin_voigt, hertz, hertz_ln, hunt_crossley, flores) or piecewise (impulse)".into(),
        ));
        let number = |key, scope| {
            let value = law_value(&law, key).unwrap_or_default();
            law_variable(&c.name, key, value, t(key), scope)
        };
        for key in [LawKey::Restitution, LawKey::Exponent, LawKey::Damping] {
            v.push(number(key, ""));
        }
        v.push(number(
            LawKey::MaxPenetration,
            if c.max_penetration.is_some() {
                ""
            } else {
                "; by default the sphere radius, following its parameter while this one keeps its start value"
            },
        ));
        v.push(number(LawKey::MinImpactVelocity, ""));
        // a stiffness the scene does not give is derived from the materials: a calculated
        // parameter
        v.push(match c.stiffness {
            Some(_) => number(LawKey::Stiffness, ""),
            None => Variable {
                name: format!("{}.stiffness", c.name),
                vtype: VarType::Real,
                causality: Causality::CalculatedParameter,
                variability: Variability::Fixed,
                start: None,
                unit: None,
                display_unit: None,
                description: "contact stiffness K of F = K delta^n [N/m^n], derived from the two materials (Hertz)"
                    .into(),
                range: None,
                target: t(LawKey::Stiffness),
                depends_on_inputs: false,
            },
        });
    }
}

/// The solver's settings.
pub(super) fn solver(scene: &Scene, v: &mut Vec<Variable>) {
    let s = &scene.solver;
    v.push(enum_param(
        "solver.method".into(),
        EnumType::SolverMethod,
        s.method as i64,
        VarRef::SolverMethod,
        "integration method: auto (dopri5 while not stiff, radau5 while stiff; the default), dopri5 (adaptive explicit), sdirk, radau5 (adaptive implicit), rk4 (fixed step = solver.max_step)".into(),
    ));
    v.push(param(
        "solver.rtol".into(),
        s.rtol,
        None,
        Range::closed(RTOL_RANGE),
        VarRef::SolverRtol,
        "relative tolerance of the adaptive methods",
    ));
    v.push(param(
        "solver.atol".into(),
        s.atol,
        None,
        Range::closed(ATOL_RANGE),
        VarRef::SolverAtol,
        "absolute tolerance of the adaptive methods (in the unit of each state component)",
    ));
    v.push(param(
        "solver.max_step".into(),
        s.max_step,
        Some("s"),
        Range::open_above(0.0, false),
        VarRef::SolverMaxStep,
        "largest internal step; 0: none (rk4: its fixed step; 0: 1 ms)",
    ));
}

/// The inputs (a `joint_motion` gives three).
pub(super) fn inputs(scene: &Scene, v: &mut Vec<Variable>) {
    let (first_value, _) = scene.input_values();
    let input_start = scene.input_start_values();
    for (i, inp) in scene.input.iter().enumerate() {
        if inp.kind == InputType::JointMotion {
            v.extend(super::motion::motion_inputs(scene, inp, first_value[i], &input_start));
            continue;
        }
        let direction = inp.direction.unwrap_or([1.0, 0.0, 0.0]);
        let direction = format!("({}, {}, {})", direction[0], direction[1], direction[2]);
        let on = |key: &Option<String>| key.clone().unwrap_or_default();
        let (unit, description) = match inp.kind {
            InputType::Force => (
                "N",
                format!(
                    "force on body '{}' at its centre of mass along the world direction {direction}",
                    on(&inp.body)
                ),
            ),
            InputType::Torque => (
                "N.m",
                format!(
                    "torque on body '{}' about the world direction {direction}",
                    on(&inp.body)
                ),
            ),
            InputType::JointMotion => unreachable!("handled above"),
            InputType::JointForce => {
                let names: Vec<String> = inp.joint.iter().chain(inp.joints.iter().flatten()).cloned().collect();
                let revolute = scene
                    .joint
                    .iter()
                    .any(|j| names.first() == Some(&j.name) && j.kind == JointType::Revolute);
                let (what, unit, along) = if revolute {
                    ("torque", "N.m", "about its axis")
                } else {
                    ("force", "N", "along its axis")
                };
                match names.as_slice() {
                    [joint] => (unit, format!("{what} on joint '{joint}' {along}")),
                    _ => (
                        unit,
                        format!("{what} on each of the joints '{}', {along}", names.join("', '")),
                    ),
                }
            }
        };
        v.push(Variable {
            name: inp.name.clone(),
            vtype: VarType::Real,
            causality: Causality::Input,
            variability: Variability::Continuous,
            start: Some(inp.start),
            unit: Some(unit),
            display_unit: None,
            description: format!("{description}; held constant over a communication step"),
            range: None,
            target: VarRef::Input(first_value[i]),
            depends_on_inputs: false,
        });
    }
}

/// The outputs: bodies, joints, contacts, energies, counters.
pub(super) fn outputs(scene: &Scene, v: &mut Vec<Variable>) {
    for (i, b) in scene.body.iter().enumerate() {
        let vectors: [(_, _, ComponentRef, _, _); 3] = [
            ("r", "m", VarRef::BodyPosition, "centre-of-mass position", Some("mm")),
            (
                "v",
                "m/s",
                VarRef::BodyVelocity,
                "centre-of-mass velocity",
                Some("km/h"),
            ),
            ("w", "rad/s", VarRef::BodyAngularVelocity, "angular velocity", None),
        ];
        for (key, unit, target, what, display_unit) in vectors {
            let components = world_vector(&b.name, key, unit, |k| target(i, k), what, false);
            v.extend(components.map(|x| Variable { display_unit, ..x }));
        }
        for (k, part) in ["w (scalar part)", "x", "y", "z"].iter().enumerate() {
            v.push(out(
                format!("{}.q[{}]", b.name, k + 1),
                VarType::Real,
                None,
                VarRef::BodyQuaternion(i, k),
                format!("orientation quaternion (principal axes to world), {part}"),
            ));
        }
    }
    for (i, j) in scene.joint.iter().enumerate() {
        if matches!(j.kind, JointType::Revolute | JointType::Prismatic) {
            let [unit, rate_unit, _] = joint_units(j.kind);
            let (what, display) = if j.kind == JointType::Revolute {
                ("angle about", "deg")
            } else {
                ("displacement along", "mm")
            };
            v.push(with_display(
                out(
                    format!("{}.q", j.name),
                    VarType::Real,
                    Some(unit),
                    VarRef::JointQ(i),
                    format!("joint {what} its axis, 0 at the initial configuration"),
                ),
                display,
            ));
            v.push(out(
                format!("{}.qd", j.name),
                VarType::Real,
                Some(rate_unit),
                VarRef::JointQd(i),
                format!("joint rate, time derivative of {}.q", j.name),
            ));
        }
    }
    let has_inputs = !scene.input.is_empty();
    for (i, c) in scene.contact.iter().enumerate() {
        v.push(with_display(
            out(
                format!("{}.delta", c.name),
                VarType::Real,
                Some("m"),
                VarRef::ContactDelta(i),
                "penetration (0 when apart)".into(),
            ),
            "mm",
        ));
        v.push(out(
            format!("{}.delta_dot", c.name),
            VarType::Real,
            Some("m/s"),
            VarRef::ContactDeltaDot(i),
            "penetration rate (0 when apart)".into(),
        ));
        // A resting impulse-law contact carries a constraint force, solved together with
        // the applied forces, which include the inputs (docs/fmi.md, "Dependencies").
        let mut force = out(
            format!("{}.force", c.name),
            VarType::Real,
            Some("N"),
            VarRef::ContactForce(i),
            "normal force magnitude".into(),
        );
        force.depends_on_inputs = has_inputs;
        v.push(force);
        v.push(out(
            format!("{}.active", c.name),
            VarType::Boolean,
            None,
            VarRef::ContactActive(i),
            "in contact (continuous laws: penetrating; impulse law: resting)".into(),
        ));
        v.push(out(
            format!("{}.impacts", c.name),
            VarType::Integer,
            None,
            VarRef::ContactImpacts(i),
            "impacts resolved so far (impulse law)".into(),
        ));
    }
    for (name, t, d) in [
        ("energy.kinetic", VarRef::EnergyKinetic, "kinetic energy"),
        (
            "energy.potential",
            VarRef::EnergyPotential,
            "potential energy of gravity and springs",
        ),
        (
            "energy.contact",
            VarRef::EnergyContact,
            "elastic energy stored in the contacts",
        ),
        (
            "energy.total",
            VarRef::EnergyTotal,
            "kinetic + potential + contact energy",
        ),
        (
            "energy.dissipated",
            VarRef::EnergyDissipated,
            "work removed by dampers, contact damping, friction and impacts since initialisation",
        ),
    ] {
        v.push(out(name.into(), VarType::Real, Some("J"), t, d.into()));
    }
    v.push(out(
        "solver.steps".into(),
        VarType::Integer,
        None,
        VarRef::SolverSteps,
        "accepted integration steps since initialisation".into(),
    ));
    v.push(out(
        "solver.rhs_evals".into(),
        VarType::Integer,
        None,
        VarRef::SolverRhsEvals,
        "right-hand-side evaluations since initialisation".into(),
    ));
}

/// The parameters added later: the step budget, spring-dampers and initial velocities, the
/// Integer twins of the enumerations, friction, inertias and contact geometry.
pub(super) fn later_parameters(scene: &Scene, v: &mut Vec<Variable>) {
    let pos = Range::open_above(0.0, true);
    let nonneg = Range::open_above(0.0, false);
    let s = &scene.solver;
    let has_inputs = !scene.input.is_empty();
    // added after the variables above: their value references do not move
    v.push(Variable {
        name: "solver.max_steps".into(),
        vtype: VarType::Integer,
        causality: Causality::Parameter,
        variability: Variability::Fixed,
        start: Some(s.max_steps as f64),
        unit: None,
        display_unit: None,
        description: "most integrator steps one communication step may take; beyond them the step stops at the \
                      last time reached (FMI 2.0: fmi2Discard, fmi2LastSuccessfulTime; FMI 3.0: an early return \
                      with fmi3Warning where early return is allowed, else fmi3Error; fmi3Discard, the \
                      instance unchanged, when it reached no further)"
            .into(),
        range: Some(Range::closed([1.0, MAX_STEPS_LIMIT as f64])),
        target: VarRef::SolverMaxSteps,
        depends_on_inputs: false,
    });
    // Spring-dampers and initial velocities as parameters (after the variables above, so
    // their value references do not move).
    for (i, sd) in scene.spring_damper.iter().enumerate() {
        let free = sd.free_length_or_default();
        v.push(param(
            format!("{}.stiffness", sd.name),
            sd.stiffness,
            Some("N/m"),
            nonneg,
            VarRef::SpringStiffness(i),
            "spring stiffness",
        ));
        v.push(param(
            format!("{}.damping", sd.name),
            sd.damping,
            Some("N.s/m"),
            nonneg,
            VarRef::SpringDamping(i),
            "damping coefficient",
        ));
        v.push(param(
            format!("{}.free_length", sd.name),
            free,
            Some("m"),
            nonneg,
            VarRef::SpringFreeLength(i),
            "length at which the spring force is zero (default: the initial distance)",
        ));
    }
    // (a speed beyond RUNAWAY_SPEED is taken for a blow-up at the first step)
    let speed = Range::closed([-RUNAWAY_SPEED, RUNAWAY_SPEED]);
    for (i, b) in scene.body.iter().enumerate() {
        let what = "initial centre-of-mass velocity, world frame (projected onto the joints)";
        let velocity = |k| VarRef::InitialVelocity(i, k);
        v.extend(param_triple(
            &b.name, "velocity", b.velocity, "m/s", speed, velocity, what,
        ));
        let what = "initial angular velocity, world frame (projected onto the joints)";
        let angular_velocity = |k| VarRef::InitialAngularVelocity(i, k);
        v.extend(param_triple(
            &b.name,
            "angular_velocity",
            b.angular_velocity,
            "rad/s",
            speed,
            angular_velocity,
            what,
        ));
    }
    // Integer twins of the enumerations, for hosts that ignore Enumeration variables. They
    // come after the variables above, so those value references do not move. 0 (the start) leaves the
    // enumeration in charge; any other value overrides it (`set_parameter` writes the
    // table in order, and 0 is no item).
    for (i, c) in scene.contact.iter().enumerate() {
        v.push(integer_twin(
            format!("{}.law_index", c.name),
            EnumType::ContactLaw,
            &format!("{}.law", c.name),
            VarRef::Contact(i, LawKey::Law),
        ));
    }
    v.push(integer_twin(
        "solver.method_index".into(),
        EnumType::SolverMethod,
        "solver.method",
        VarRef::SolverMethod,
    ));
    // Friction (after everything above, so that no value reference moves).
    for (i, c) in scene.contact.iter().enumerate() {
        let law = crate::compile::contact_law_constants(c);
        for key in FRICTION_KEYS {
            let value = law_value(&law, key).unwrap_or_default();
            v.push(law_variable(&c.name, key, value, VarRef::Contact(i, key), ""));
        }
    }
    for (i, c) in scene.contact.iter().enumerate() {
        // A resting impulse-law contact's friction follows its normal force, a constraint force
        // solved with the applied forces (inputs included), like `<contact>.force`.
        let friction = |k| VarRef::ContactFrictionForce(i, k);
        v.extend(world_vector(
            &c.name,
            "friction_force",
            "N",
            friction,
            "friction force on the sphere",
            has_inputs,
        ));
        v.push(out(
            format!("{}.slip_velocity", c.name),
            VarType::Real,
            Some("m/s"),
            VarRef::ContactSlipVelocity(i),
            "slip speed: tangential velocity of the sphere's contact point relative to the other body's".into(),
        ));
    }
    // Inertias and contact geometry, after the twins (no value reference above moves).
    // Lengths have the range of the scene's lengths: > 0 and at most MAX_MAGNITUDE.
    let length = Range {
        min: 0.0,
        min_exclusive: true,
        max: MAX_MAGNITUDE,
        max_exclusive: false,
    };
    for (i, b) in scene.body.iter().enumerate() {
        let what = "principal moment of inertia about the centre of mass (the three satisfy the triangle inequality)";
        v.extend(param_triple(
            &b.name,
            "inertia",
            b.inertia,
            "kg.m2",
            pos,
            |k| VarRef::Inertia(i, k),
            what,
        ));
    }
    for (i, c) in scene.contact.iter().enumerate() {
        v.push(param(
            format!("{}.radius", c.name),
            c.radius,
            Some("m"),
            length,
            VarRef::SphereRadius(i),
            "radius of the sphere (the Hertz stiffness derived from the materials follows it)",
        ));
        match c.kind {
            ContactType::SphereSphere => v.push(param(
                format!("{}.other_radius", c.name),
                c.other_radius.unwrap_or(1.0),
                Some("m"),
                length,
                VarRef::OtherRadius(i),
                "radius of the other sphere",
            )),
            ContactType::SpherePlane => {
                let size = c.size.unwrap_or([1.0, 1.0]);
                for (k, axis) in ["u_axis", "normal x u_axis"].iter().enumerate() {
                    v.push(param(
                        format!("{}.size[{}]", c.name, k + 1),
                        size[k],
                        Some("m"),
                        length,
                        VarRef::PlaneSize(i, k),
                        &format!("side length of the rectangle along {axis}"),
                    ));
                }
            }
            ContactType::SphereCylinder => {
                v.push(param(
                    format!("{}.cylinder_radius", c.name),
                    c.cylinder_radius.unwrap_or(1.0),
                    Some("m"),
                    length,
                    VarRef::CylinderRadius(i),
                    "radius of the cylinder (inside contact: larger than the sphere's)",
                ));
                v.push(param(
                    format!("{}.length", c.name),
                    c.length.unwrap_or(1.0),
                    Some("m"),
                    length,
                    VarRef::CylinderLength(i),
                    "length of the cylinder patch along its axis",
                ));
            }
        }
    }
}

/// The outputs added last (after the contact groups' and the drives' variables: the value
/// references before them do not move): the count of located contact events.
pub(super) fn later_outputs(v: &mut Vec<Variable>) {
    v.push(out(
        "solver.events".into(),
        VarType::Integer,
        None,
        VarRef::SolverEvents,
        "contact events located since initialisation (the instants at which the integration stopped for a \
         touch, separation, impact, rest or release, a damping force cut at zero or its end, or a change \
         between sticking and slipping; several contacts changing at one instant count once)"
            .into(),
    ));
}
