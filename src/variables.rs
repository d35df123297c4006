//! The table of a scene's user-visible variables: parameters, inputs and outputs, with the
//! names fixed by `README.md` ("FMU variables"). It is a pure function of the scene; the FMI layer and the
//! exporter read it, the simulation answers get/set by index into it.
//!
//! The value reference of a variable is its index in [`VariableTable::vars`].

use crate::compile::Parameters;
use crate::scene::{ContactType, InputType, JointType, Law, Method, Scene, ATOL_RANGE, MAX_MAGNITUDE, RTOL_RANGE};

/// Value type as seen by FMI.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VarType {
    /// fmi2Real
    Real,
    /// fmi2Integer
    Integer,
    /// fmi2Boolean
    Boolean,
    /// An Integer-valued enumeration with a declared type.
    Enumeration(EnumType),
}

/// The enumeration types declared in TypeDefinitions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EnumType {
    /// `<contact>.law`
    ContactLaw,
    /// `solver.method`
    SolverMethod,
}

impl EnumType {
    /// The declared type's name.
    pub fn type_name(self) -> &'static str {
        match self {
            EnumType::ContactLaw => "ContactLaw",
            EnumType::SolverMethod => "SolverMethod",
        }
    }
    /// (name, value) items.
    pub fn items(self) -> Vec<(&'static str, i64)> {
        match self {
            EnumType::ContactLaw => Law::ALL.iter().map(|l| (l.name(), *l as i64)).collect(),
            EnumType::SolverMethod => Method::ALL.iter().map(|m| (m.name(), *m as i64)).collect(),
        }
    }
}

/// FMI causality.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Causality {
    /// Set by the user before initialisation.
    Parameter,
    /// Computed from parameters at initialisation.
    CalculatedParameter,
    /// Set by the host at any communication point.
    Input,
    /// Computed.
    Output,
}

/// FMI variability.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variability {
    /// Fixed after initialisation.
    Fixed,
    /// A parameter that may also change between communication points after initialisation
    /// (it takes effect from the next step on).
    Tunable,
    /// Changes at events only (Integer/Boolean outputs).
    Discrete,
    /// Real inputs and outputs.
    Continuous,
}

impl Causality {
    /// The name FMI gives it (`causality` attribute).
    pub fn name(self) -> &'static str {
        match self {
            Causality::Parameter => "parameter",
            Causality::CalculatedParameter => "calculatedParameter",
            Causality::Input => "input",
            Causality::Output => "output",
        }
    }
}

impl Variability {
    /// The name FMI gives it (`variability` attribute).
    pub fn name(self) -> &'static str {
        match self {
            Variability::Fixed => "fixed",
            Variability::Tunable => "tunable",
            Variability::Discrete => "discrete",
            Variability::Continuous => "continuous",
        }
    }
}

/// What a variable refers to inside the simulation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VarRef {
    /// material index: E
    YoungsModulus(usize),
    /// material index: ν
    PoissonRatio(usize),
    /// body index (scene order): mass
    Mass(usize),
    /// body index, component 0..3: principal moment of inertia
    Inertia(usize, usize),
    /// contact index: law (`<contact>.law` and its Integer twin `<contact>.law_index`)
    ContactLaw(usize),
    /// contact index: e
    Restitution(usize),
    /// contact index: exponent n
    Exponent(usize),
    /// contact index: Kelvin-Voigt damping
    Damping(usize),
    /// contact index: δ_max
    MaxPenetration(usize),
    /// contact index: floor of δ̇⁻
    MinImpactVelocity(usize),
    /// contact index: K (parameter or calculated)
    Stiffness(usize),
    /// contact index: Coulomb friction coefficient μ
    Friction(usize),
    /// contact index: static friction coefficient μ_s
    StaticFriction(usize),
    /// contact index: Stribeck velocity
    StribeckVelocity(usize),
    /// contact index: viscous friction coefficient σ
    ViscousFriction(usize),
    /// contact index: regularisation (stiction) velocity
    StictionVelocity(usize),
    /// contact index: radius of the sphere
    SphereRadius(usize),
    /// contact index: radius of the other sphere (sphere_sphere)
    OtherRadius(usize),
    /// contact index, component 0..2: side length of the rectangle (sphere_plane)
    PlaneSize(usize, usize),
    /// contact index: radius of the cylinder (sphere_cylinder)
    CylinderRadius(usize),
    /// contact index: length of the cylinder patch (sphere_cylinder)
    CylinderLength(usize),
    /// solver.method (and its Integer twin solver.method_index)
    SolverMethod,
    /// solver.rtol
    SolverRtol,
    /// solver.atol
    SolverAtol,
    /// solver.max_step
    SolverMaxStep,
    /// solver.max_steps
    SolverMaxSteps,
    /// spring-damper index: stiffness
    SpringStiffness(usize),
    /// spring-damper index: damping
    SpringDamping(usize),
    /// spring-damper index: free length
    SpringFreeLength(usize),
    /// body index, component: initial centre-of-mass velocity
    InitialVelocity(usize, usize),
    /// body index, component: initial angular velocity
    InitialAngularVelocity(usize, usize),
    /// input index
    Input(usize),
    /// body index, component 0..3 of the centre-of-mass position
    BodyPosition(usize, usize),
    /// body index, component of the centre-of-mass velocity
    BodyVelocity(usize, usize),
    /// body index, component of the world angular velocity
    BodyAngularVelocity(usize, usize),
    /// body index, quaternion component 0..4 (w, x, y, z)
    BodyQuaternion(usize, usize),
    /// joint index (scene order): coordinate
    JointQ(usize),
    /// joint index: rate
    JointQd(usize),
    /// contact index: penetration δ
    ContactDelta(usize),
    /// contact index: δ̇
    ContactDeltaDot(usize),
    /// contact index: normal force
    ContactForce(usize),
    /// contact index: Boolean in contact
    ContactActive(usize),
    /// contact index: Integer impacts resolved
    ContactImpacts(usize),
    /// contact index, component: friction force on the sphere, world frame
    ContactFrictionForce(usize, usize),
    /// contact index: slip speed
    ContactSlipVelocity(usize),
    /// energy.kinetic
    EnergyKinetic,
    /// energy.potential
    EnergyPotential,
    /// energy.contact
    EnergyContact,
    /// energy.total
    EnergyTotal,
    /// energy.dissipated
    EnergyDissipated,
    /// energy.input_work
    EnergyInputWork,
    /// drive index (a `joint_motion` input, in scene order): `<input>.force`
    DriveForce(usize),
    /// solver.steps
    SolverSteps,
    /// solver.rhs_evals
    SolverRhsEvals,
    /// contact group pair index, key: a law constant of every contact of the pair
    Group(usize, GroupKey),
    /// body index, component: total contact force on the body, world frame
    BodyContactForce(usize, usize),
    /// body index, component: total contact torque about the centre of mass, world frame
    BodyContactTorque(usize, usize),
    /// contact group pair index: Integer number of contacts in contact
    GroupActive(usize),
    /// contact group pair index: largest penetration of its contacts
    GroupLargestPenetration(usize),
}

/// The law constants of a contact group pair that are FMU parameters (`<pair>.<key>`, the
/// keys of a `[[contact]]`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GroupKey {
    /// `law` (and its Integer twin `law_index`)
    Law,
    /// `restitution`
    Restitution,
    /// `exponent`
    Exponent,
    /// `damping`
    Damping,
    /// `max_penetration` (when the scene gives it)
    MaxPenetration,
    /// `min_impact_velocity`
    MinImpactVelocity,
    /// `stiffness` (when the scene gives it)
    Stiffness,
    /// `friction`
    Friction,
    /// `static_friction`
    StaticFriction,
    /// `stribeck_velocity`
    StribeckVelocity,
    /// `viscous_friction`
    ViscousFriction,
    /// `stiction_velocity`
    StictionVelocity,
}

/// One variable.
#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    /// Structured name, e.g. `arm.r[1]`.
    pub name: String,
    /// Value type.
    pub vtype: VarType,
    /// Causality.
    pub causality: Causality,
    /// Variability.
    pub variability: Variability,
    /// Start value (parameters, inputs; also the initial value of outputs, `None` when the
    /// output is calculated at initialisation).
    pub start: Option<f64>,
    /// Unit name (declared in UnitDefinitions), if any.
    pub unit: Option<&'static str>,
    /// The display unit a host shows by default (one of the unit's display units in
    /// [`UNITS`]), if any.
    pub display_unit: Option<&'static str>,
    /// Description.
    pub description: String,
    /// Allowed range of a parameter, checked when initialisation ends (inclusive unless the
    /// exclusive flags say otherwise).
    pub range: Option<Range>,
    /// What it refers to.
    pub target: VarRef,
    /// Outputs: true when the value at a communication point is an algebraic function of the
    /// inputs set at that point (listed in `ModelStructure/Outputs` as `dependencies`); false
    /// when it follows from the state alone (`dependencies=""`). See docs/fmi.md.
    pub depends_on_inputs: bool,
}

/// A parameter's allowed range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Range {
    /// Lower bound.
    pub min: f64,
    /// Lower bound excluded.
    pub min_exclusive: bool,
    /// Upper bound.
    pub max: f64,
    /// Upper bound excluded.
    pub max_exclusive: bool,
}

impl Range {
    fn open_above(min: f64, min_exclusive: bool) -> Range {
        Range {
            min,
            min_exclusive,
            max: f64::INFINITY,
            max_exclusive: false,
        }
    }
    fn closed([min, max]: [f64; 2]) -> Range {
        Range {
            min,
            min_exclusive: false,
            max,
            max_exclusive: false,
        }
    }
    /// True when `v` lies in the range.
    pub fn contains(&self, v: f64) -> bool {
        let lo = if self.min_exclusive {
            v > self.min
        } else {
            v >= self.min
        };
        let hi = if self.max_exclusive {
            v < self.max
        } else {
            v <= self.max
        };
        v.is_finite() && lo && hi
    }
    /// Human-readable form, e.g. `(0, inf)`, `[0, 0.5)` or `[1e-14, 0.01]`.
    pub fn describe(&self) -> String {
        // the shorter of plain and scientific notation
        let num = |x: f64| {
            let (plain, sci) = (format!("{x}"), format!("{x:e}"));
            if sci.len() < plain.len() {
                sci
            } else {
                plain
            }
        };
        format!(
            "{}{}, {}{}",
            if self.min_exclusive { "(" } else { "[" },
            num(self.min),
            num(self.max),
            if self.max_exclusive { ")" } else { "]" }
        )
    }
}

/// A unit of UnitDefinitions (SI).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Unit {
    /// Name, as the variables' `unit` attribute gives it.
    pub name: &'static str,
    /// Exponents of the base units kg, m, s and rad, in that order.
    pub base: [i32; 4],
    /// Display units: (name, factor), value in the display unit = factor × value in the unit.
    pub display: &'static [(&'static str, f64)],
}

/// The units the variables use, for UnitDefinitions, with the display units engineers read
/// (mm, km/h, deg, rpm).
pub const UNITS: &[Unit] = &[
    Unit {
        name: "m",
        base: [0, 1, 0, 0],
        display: &[("mm", 1e3)],
    },
    Unit {
        name: "m/s",
        base: [0, 1, -1, 0],
        display: &[("km/h", 3.6), ("mm/s", 1e3)],
    },
    Unit {
        name: "rad",
        base: [0, 0, 0, 1],
        display: &[("deg", 180.0 / std::f64::consts::PI)],
    },
    Unit {
        name: "rad/s",
        base: [0, 0, -1, 1],
        display: &[
            ("deg/s", 180.0 / std::f64::consts::PI),
            ("rpm", 30.0 / std::f64::consts::PI),
        ],
    },
    Unit {
        name: "m/s2",
        base: [0, 1, -2, 0],
        display: &[],
    },
    Unit {
        name: "rad/s2",
        base: [0, 0, -2, 1],
        display: &[("deg/s2", 180.0 / std::f64::consts::PI)],
    },
    Unit {
        name: "kg",
        base: [1, 0, 0, 0],
        display: &[],
    },
    Unit {
        name: "N",
        base: [1, 1, -2, 0],
        display: &[("kN", 1e-3)],
    },
    Unit {
        name: "N.m",
        base: [1, 2, -2, 0],
        display: &[],
    },
    Unit {
        name: "J",
        base: [1, 2, -2, 0],
        display: &[],
    },
    Unit {
        name: "Pa",
        base: [1, -1, -2, 0],
        display: &[("GPa", 1e-9)],
    },
    Unit {
        name: "s",
        base: [0, 0, 1, 0],
        display: &[("ms", 1e3)],
    },
    Unit {
        name: "N.s/m",
        base: [1, 0, -1, 0],
        display: &[],
    },
    Unit {
        name: "N/m",
        base: [1, 0, -2, 0],
        display: &[],
    },
    Unit {
        name: "s/m",
        base: [0, -1, 1, 0],
        display: &[],
    },
    Unit {
        name: "kg.m2",
        base: [1, 2, 0, 0],
        display: &[],
    },
];

/// The unit of a 1-DOF joint's coordinate and of its rate: rad and rad/s (revolute), m and
/// m/s (prismatic).
fn joint_units(kind: JointType) -> (&'static str, &'static str) {
    if kind == JointType::Revolute {
        ("rad", "rad/s")
    } else {
        ("m", "m/s")
    }
}

/// `x`, `y`, `z` for the components 0, 1, 2 of a world vector.
const AXES: [&str; 3] = ["x", "y", "z"];

/// All variables of a scene, in value-reference order.
#[derive(Debug, Clone)]
pub struct VariableTable {
    /// The variables; index = value reference.
    pub vars: Vec<Variable>,
    /// The value references of the inputs that move a driven joint when set (`<drive>.q`,
    /// `<drive>.qd`): every output read from the state depends on them at once.
    pub moving_inputs: Vec<usize>,
}

impl VariableTable {
    /// Builds the table from a (validated) scene.
    pub fn from_scene(scene: &Scene) -> VariableTable {
        let mut v = Vec::new();
        let param = |name: String, start: f64, unit, range: Range, target, description: &str| Variable {
            name,
            vtype: VarType::Real,
            causality: Causality::Parameter,
            variability: Variability::Fixed,
            start: Some(start),
            unit,
            display_unit: None,
            description: description.to_string(),
            range: Some(range),
            target,
            depends_on_inputs: false,
        };
        // Contact-law constants may change between communication points (docs/fmi.md).
        let tunable = |mut var: Variable| {
            var.variability = Variability::Tunable;
            var
        };
        let pos = Range::open_above(0.0, true);
        let nonneg = Range::open_above(0.0, false);
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
            v.push(Variable {
                name: format!("{}.law", c.name),
                vtype: VarType::Enumeration(EnumType::ContactLaw),
                causality: Causality::Parameter,
                variability: Variability::Fixed,
                start: Some(c.law as i64 as f64),
                unit: None,
                display_unit: None,
                description: "contact force law: continuous (kelvin_voigt, hertz, hertz_ln, hunt_crossley, flores) or piecewise (impulse)".into(),
                range: Some(Range {
                    min: 1.0,
                    min_exclusive: false,
                    max: 6.0,
                    max_exclusive: false,
                }),
                target: VarRef::ContactLaw(i),
                depends_on_inputs: false,
            });
            v.push(tunable(param(
                format!("{}.restitution", c.name),
                c.restitution,
                None,
                Range {
                    min: 0.0,
                    min_exclusive: false,
                    max: 1.0,
                    max_exclusive: false,
                },
                VarRef::Restitution(i),
                "coefficient of restitution e",
            )));
            v.push(tunable(param(
                format!("{}.exponent", c.name),
                c.exponent.unwrap_or(1.5),
                None,
                Range::open_above(1.0, false),
                VarRef::Exponent(i),
                "force exponent n of the penetration (1.5 for Hertz)",
            )));
            v.push(tunable(param(
                format!("{}.damping", c.name),
                c.damping.unwrap_or(0.0),
                Some("N.s/m"),
                nonneg,
                VarRef::Damping(i),
                "Kelvin-Voigt damping coefficient",
            )));
            v.push(param(
                format!("{}.max_penetration", c.name),
                c.max_penetration_or_default(),
                Some("m"),
                pos,
                VarRef::MaxPenetration(i),
                if c.max_penetration.is_some() {
                    "largest admissible penetration (a deeper one fails the step)"
                } else {
                    "largest admissible penetration (a deeper one fails the step); by default the sphere radius, \
                     following its parameter while this one keeps its start value"
                },
            ));
            v.push(param(
                format!("{}.min_impact_velocity", c.name),
                c.min_impact_velocity_or_default(),
                Some("m/s"),
                nonneg,
                VarRef::MinImpactVelocity(i),
                "floor on the remembered impact velocity; impulse law: approach speeds below it rest instead of bouncing",
            ));
            let k = Variable {
                name: format!("{}.stiffness", c.name),
                vtype: VarType::Real,
                causality: if c.stiffness.is_some() {
                    Causality::Parameter
                } else {
                    Causality::CalculatedParameter
                },
                variability: if c.stiffness.is_some() {
                    Variability::Tunable
                } else {
                    Variability::Fixed
                },
                start: c.stiffness,
                // N/m^n: the unit depends on the exponent n, so it is stated in the description.
                unit: None,
                display_unit: None,
                description: if c.stiffness.is_some() {
                    "contact stiffness K of F = K delta^n [N/m^n]".into()
                } else {
                    "contact stiffness K of F = K delta^n [N/m^n], derived from the two materials (Hertz)".into()
                },
                range: c.stiffness.map(|_| pos),
                target: VarRef::Stiffness(i),
                depends_on_inputs: false,
            };
            v.push(k);
        }
        let s = &scene.solver;
        v.push(Variable {
            name: "solver.method".into(),
            vtype: VarType::Enumeration(EnumType::SolverMethod),
            causality: Causality::Parameter,
            variability: Variability::Fixed,
            start: Some(s.method as i64 as f64),
            unit: None,
            display_unit: None,
            description: "integration method: auto (dopri5 while not stiff, radau5 while stiff; the default), dopri5 (adaptive explicit), sdirk, radau5 (adaptive implicit), rk4 (fixed step = solver.max_step)".into(),
            range: Some(Range {
                min: 1.0,
                min_exclusive: false,
                max: Method::ALL.len() as f64,
                max_exclusive: false,
            }),
            target: VarRef::SolverMethod,
            depends_on_inputs: false,
        });
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
        let (first_value, _) = scene.input_values();
        let input_start = scene.input_start_values();
        for (i, inp) in scene.input.iter().enumerate() {
            if inp.kind == InputType::JointMotion {
                v.extend(motion_inputs(scene, inp, first_value[i], &input_start));
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
        let out =
            |name, vtype, unit, target, description| output_variable(name, vtype, unit, target, description, false);
        let with_display = |mut var: Variable, display: &'static str| {
            var.display_unit = Some(display);
            var
        };
        for (i, b) in scene.body.iter().enumerate() {
            for (k, axis) in AXES.iter().enumerate() {
                v.push(with_display(
                    out(
                        format!("{}.r[{}]", b.name, k + 1),
                        VarType::Real,
                        Some("m"),
                        VarRef::BodyPosition(i, k),
                        format!("centre-of-mass position, world {axis}"),
                    ),
                    "mm",
                ));
            }
            for (k, axis) in AXES.iter().enumerate() {
                v.push(with_display(
                    out(
                        format!("{}.v[{}]", b.name, k + 1),
                        VarType::Real,
                        Some("m/s"),
                        VarRef::BodyVelocity(i, k),
                        format!("centre-of-mass velocity, world {axis}"),
                    ),
                    "km/h",
                ));
            }
            for (k, axis) in AXES.iter().enumerate() {
                v.push(out(
                    format!("{}.w[{}]", b.name, k + 1),
                    VarType::Real,
                    Some("rad/s"),
                    VarRef::BodyAngularVelocity(i, k),
                    format!("angular velocity, world {axis}"),
                ));
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
                let (unit, rate_unit) = joint_units(j.kind);
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
        // added after the variables above: their value references do not move
        v.push(Variable {
            name: "solver.max_steps".into(),
            vtype: VarType::Integer,
            causality: Causality::Parameter,
            variability: Variability::Fixed,
            start: Some(s.max_steps as f64),
            unit: None,
            display_unit: None,
            description: "most integrator steps one communication step may take; beyond them fmi2DoStep returns \
                          fmi2Discard at the last time reached (fmi2LastSuccessfulTime)"
                .into(),
            range: Some(Range {
                min: 1.0,
                min_exclusive: false,
                max: i32::MAX as f64,
                max_exclusive: false,
            }),
            target: VarRef::SolverMaxSteps,
            depends_on_inputs: false,
        });
        // Spring-dampers and initial velocities as parameters (after the variables above, so
        // their value references do not move).
        let finite = Range::closed([-1e12, 1e12]);
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
        for (i, b) in scene.body.iter().enumerate() {
            for k in 0..3 {
                v.push(param(
                    format!("{}.velocity[{}]", b.name, k + 1),
                    b.velocity[k],
                    Some("m/s"),
                    finite,
                    VarRef::InitialVelocity(i, k),
                    "initial centre-of-mass velocity, world frame (projected onto the joints)",
                ));
            }
            for k in 0..3 {
                v.push(param(
                    format!("{}.angular_velocity[{}]", b.name, k + 1),
                    b.angular_velocity[k],
                    Some("rad/s"),
                    finite,
                    VarRef::InitialAngularVelocity(i, k),
                    "initial angular velocity, world frame (projected onto the joints)",
                ));
            }
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
                VarRef::ContactLaw(i),
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
            let [mu, mu_s, v_st, sigma, v_s] = c.friction_or_default();
            for (key, value, unit, range, target, description) in [
                ("friction", mu, None, nonneg, VarRef::Friction(i), "Coulomb (sliding) friction coefficient mu (0: frictionless)"),
                ("static_friction", mu_s, None, nonneg, VarRef::StaticFriction(i), "static friction coefficient mu_s, the peak of the Stribeck curve at zero slip"),
                ("stribeck_velocity", v_st, Some("m/s"), pos, VarRef::StribeckVelocity(i), "Stribeck velocity: the coefficient falls from mu_s to mu as exp(-(slip/v_st)^2)"),
                ("viscous_friction", sigma, Some("s/m"), nonneg, VarRef::ViscousFriction(i), "viscous friction: the coefficient grows by viscous_friction * slip speed"),
                ("stiction_velocity", v_s, Some("m/s"), pos, VarRef::StictionVelocity(i), "regularisation velocity of the continuous friction law: full friction above it, proportional below (creep)"),
            ] {
                v.push(tunable(param(format!("{}.{key}", c.name), value, unit, range, target, description)));
            }
        }
        for (i, c) in scene.contact.iter().enumerate() {
            for (k, axis) in AXES.iter().enumerate() {
                // A resting impulse-law contact's friction follows its normal force, a
                // constraint force solved with the applied forces (inputs included), like
                // `<contact>.force`.
                let mut f = out(
                    format!("{}.friction_force[{}]", c.name, k + 1),
                    VarType::Real,
                    Some("N"),
                    VarRef::ContactFrictionForce(i, k),
                    format!("friction force on the sphere, world {axis}"),
                );
                f.depends_on_inputs = has_inputs;
                v.push(f);
            }
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
            for k in 0..3 {
                v.push(param(
                    format!("{}.inertia[{}]", b.name, k + 1),
                    b.inertia[k],
                    Some("kg.m2"),
                    pos,
                    VarRef::Inertia(i, k),
                    "principal moment of inertia about the centre of mass (the three satisfy the triangle inequality)",
                ));
            }
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
        group_variables(scene, &mut v);
        motion_outputs(scene, &mut v);
        let moving_inputs = v
            .iter()
            .enumerate()
            .filter(|(_, var)| {
                var.causality == Causality::Input
                    && scene.input.iter().any(|i| {
                        i.kind == InputType::JointMotion
                            && (var.name == format!("{}.q", i.name) || var.name == format!("{}.qd", i.name))
                    })
            })
            .map(|(vr, _)| vr)
            .collect();
        VariableTable { vars: v, moving_inputs }
    }

    /// Index of a variable by name.
    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.vars.iter().position(|v| v.name == name)
    }
}

/// The three inputs of a `joint_motion` input `inp` whose values start at `first` among the
/// inputs' values: `<name>.q`, `<name>.qd`, `<name>.qdd`.
fn motion_inputs(scene: &Scene, inp: &crate::scene::InputSpec, first: usize, start: &[f64]) -> Vec<Variable> {
    let joint = inp.joint.clone().unwrap_or_default();
    let revolute = scene
        .joint
        .iter()
        .any(|j| j.name == joint && j.kind == JointType::Revolute);
    let units: [&'static str; 3] = if revolute {
        ["rad", "rad/s", "rad/s2"]
    } else {
        ["m", "m/s", "m/s2"]
    };
    let what = [
        format!(
            "coordinate of joint '{joint}' set at the start of the communication step (0: the scene's \
             configuration); setting it moves the joint there at once"
        ),
        format!(
            "rate of joint '{joint}' at the start of the communication step; setting it sets the joint's rate \
             at once (a host that sets only the coordinate gets zero rate)"
        ),
        format!("acceleration of joint '{joint}' over the communication step: the joint follows q + qd t + qdd t^2/2"),
    ];
    (0..3)
        .map(|k| Variable {
            name: format!("{}.{}", inp.name, ["q", "qd", "qdd"][k]),
            vtype: VarType::Real,
            causality: Causality::Input,
            variability: Variability::Continuous,
            start: Some(start[first + k]),
            unit: Some(units[k]),
            display_unit: None,
            description: what[k].clone(),
            range: None,
            target: VarRef::Input(first + k),
            depends_on_inputs: false,
        })
        .collect()
}

/// The outputs added with motion inputs and input work, after every other variable (so that
/// no value reference of an earlier scene moves): `energy.input_work`, and per `joint_motion`
/// input its drive force `<name>.force`.
fn motion_outputs(scene: &Scene, v: &mut Vec<Variable>) {
    v.push(output_variable(
        "energy.input_work".into(),
        VarType::Real,
        Some("J"),
        VarRef::EnergyInputWork,
        "work done on the system by every input since initialisation (forces, torques, joint forces, drives): \
         energy.total + energy.dissipated - energy.input_work stays at its initial value"
            .into(),
        false,
    ));
    for (k, inp) in scene
        .input
        .iter()
        .filter(|i| i.kind == InputType::JointMotion)
        .enumerate()
    {
        let joint = inp.joint.clone().unwrap_or_default();
        let revolute = scene
            .joint
            .iter()
            .any(|j| j.name == joint && j.kind == JointType::Revolute);
        let (unit, what) = if revolute {
            ("N.m", "torque the drive exerts on the child body about the axis")
        } else {
            ("N", "force the drive exerts on the child body along the axis")
        };
        v.push(output_variable(
            format!("{}.force", inp.name),
            VarType::Real,
            Some(unit),
            VarRef::DriveForce(k),
            format!("generalised {what} of joint '{joint}' (what an actuator supplies to follow the motion)"),
            true,
        ));
    }
}

/// The variables of the contact groups, after every other (so that no value reference of a
/// scene without groups moves): per group pair its law constants, then per body its total
/// contact force and torque, then per group pair its active count and largest penetration.
fn group_variables(scene: &Scene, v: &mut Vec<Variable>) {
    if scene.contact_group.is_empty() {
        return;
    }
    let param = |name: String, start: f64, unit, range: Range, target, tunable: bool, description: &str| Variable {
        name,
        vtype: VarType::Real,
        causality: Causality::Parameter,
        variability: if tunable {
            Variability::Tunable
        } else {
            Variability::Fixed
        },
        start: Some(start),
        unit,
        display_unit: None,
        description: format!("{description} (every contact of the group pair)"),
        range: Some(range),
        target,
        depends_on_inputs: false,
    };
    let pos = Range::open_above(0.0, true);
    let nonneg = Range::open_above(0.0, false);
    let unit_interval = Range {
        min: 0.0,
        min_exclusive: false,
        max: 1.0,
        max_exclusive: false,
    };
    for (p, g) in scene.contact_group.iter().enumerate() {
        let t = |key| VarRef::Group(p, key);
        v.push(Variable {
            name: format!("{}.law", g.name),
            vtype: VarType::Enumeration(EnumType::ContactLaw),
            causality: Causality::Parameter,
            variability: Variability::Fixed,
            start: Some(g.law as i64 as f64),
            unit: None,
            display_unit: None,
            description: "contact force law of every contact of the group pair".into(),
            range: Some(Range {
                min: 1.0,
                min_exclusive: false,
                max: 6.0,
                max_exclusive: false,
            }),
            target: t(GroupKey::Law),
            depends_on_inputs: false,
        });
        v.push(integer_twin(
            format!("{}.law_index", g.name),
            EnumType::ContactLaw,
            &format!("{}.law", g.name),
            t(GroupKey::Law),
        ));
        let template = scene.group_pair_contact(g, &g.name, &scene.shape[0], &scene.shape[0]);
        let [mu, mu_s, v_st, sigma, v_s] = template.friction_or_default();
        for (key, value, unit, range, target, tunable, description) in [
            (
                "restitution",
                g.restitution,
                None,
                unit_interval,
                GroupKey::Restitution,
                true,
                "coefficient of restitution e",
            ),
            (
                "exponent",
                g.exponent.unwrap_or(1.5),
                None,
                Range::open_above(1.0, false),
                GroupKey::Exponent,
                true,
                "force exponent n of the penetration",
            ),
            (
                "damping",
                g.damping.unwrap_or(0.0),
                Some("N.s/m"),
                nonneg,
                GroupKey::Damping,
                true,
                "Kelvin-Voigt damping coefficient",
            ),
            (
                "min_impact_velocity",
                template.min_impact_velocity_or_default(),
                Some("m/s"),
                nonneg,
                GroupKey::MinImpactVelocity,
                false,
                "floor on the remembered impact velocity",
            ),
            (
                "friction",
                mu,
                None,
                nonneg,
                GroupKey::Friction,
                true,
                "Coulomb (sliding) friction coefficient mu",
            ),
            (
                "static_friction",
                mu_s,
                None,
                nonneg,
                GroupKey::StaticFriction,
                true,
                "static friction coefficient mu_s",
            ),
            (
                "stribeck_velocity",
                v_st,
                Some("m/s"),
                pos,
                GroupKey::StribeckVelocity,
                true,
                "Stribeck velocity",
            ),
            (
                "viscous_friction",
                sigma,
                Some("s/m"),
                nonneg,
                GroupKey::ViscousFriction,
                true,
                "viscous friction coefficient",
            ),
            (
                "stiction_velocity",
                v_s,
                Some("m/s"),
                pos,
                GroupKey::StictionVelocity,
                true,
                "regularisation velocity of the continuous friction law",
            ),
        ] {
            v.push(param(
                format!("{}.{key}", g.name),
                value,
                unit,
                range,
                t(target),
                tunable,
                description,
            ));
        }
        if let Some(d) = g.max_penetration {
            v.push(param(
                format!("{}.max_penetration", g.name),
                d,
                Some("m"),
                pos,
                t(GroupKey::MaxPenetration),
                false,
                "largest admissible penetration",
            ));
        }
        if let Some(k) = g.stiffness {
            v.push(param(
                format!("{}.stiffness", g.name),
                k,
                None,
                pos,
                t(GroupKey::Stiffness),
                true,
                "contact stiffness K of F = K delta^n [N/m^n]",
            ));
        }
    }
    let depends_on_inputs = !scene.input.is_empty();
    let out = |name, vtype, unit, target, description| {
        output_variable(name, vtype, unit, target, description, depends_on_inputs)
    };
    for (b, body) in scene.body.iter().enumerate() {
        for (k, axis) in AXES.iter().enumerate() {
            v.push(out(
                format!("{}.contact_force[{}]", body.name, k + 1),
                VarType::Real,
                Some("N"),
                VarRef::BodyContactForce(b, k),
                format!("total contact force on the body (normal and friction, every contact), world {axis}"),
            ));
        }
        for (k, axis) in AXES.iter().enumerate() {
            v.push(out(
                format!("{}.contact_torque[{}]", body.name, k + 1),
                VarType::Real,
                Some("N.m"),
                VarRef::BodyContactTorque(b, k),
                format!("total contact torque on the body about its centre of mass, world {axis}"),
            ));
        }
    }
    for (p, g) in scene.contact_group.iter().enumerate() {
        v.push(out(
            format!("{}.active_contacts", g.name),
            VarType::Integer,
            None,
            VarRef::GroupActive(p),
            "number of contacts of the group pair in contact".into(),
        ));
        v.push(out(
            format!("{}.largest_penetration", g.name),
            VarType::Real,
            Some("m"),
            VarRef::GroupLargestPenetration(p),
            "largest penetration among the contacts of the group pair (0: none in contact)".into(),
        ));
    }
}

/// An Integer parameter that sets the enumeration `enum_name` (of type `e`): 0 leaves it, an
/// item's value overrides it.
/// An output: continuous when Real, discrete otherwise.
fn output_variable(
    name: String,
    vtype: VarType,
    unit: Option<&'static str>,
    target: VarRef,
    description: String,
    depends_on_inputs: bool,
) -> Variable {
    Variable {
        name,
        vtype,
        causality: Causality::Output,
        variability: if vtype == VarType::Real {
            Variability::Continuous
        } else {
            Variability::Discrete
        },
        start: None,
        unit,
        display_unit: None,
        description,
        range: None,
        target,
        depends_on_inputs,
    }
}

fn integer_twin(name: String, e: EnumType, enum_name: &str, target: VarRef) -> Variable {
    let items: Vec<String> = e.items().iter().map(|(n, i)| format!("{i} = {n}")).collect();
    Variable {
        name,
        vtype: VarType::Integer,
        causality: Causality::Parameter,
        variability: Variability::Fixed,
        start: Some(0.0),
        unit: None,
        display_unit: None,
        description: format!(
            "{enum_name} as a plain Integer, for hosts without Enumeration variables: 0 = as {enum_name}; {} (overrides {enum_name})",
            items.join(", ")
        ),
        range: Some(Range {
            min: 0.0,
            min_exclusive: false,
            max: e.items().len() as f64,
            max_exclusive: false,
        }),
        target,
        depends_on_inputs: false,
    }
}

/// Writes the value `x` of the parameter (or input start value) `target` into `params`;
/// every other variable is not a parameter and changes nothing. A law or method value that
/// is no item (0, the start of the Integer twins `<contact>.law_index` and
/// `solver.method_index`) changes nothing either.
pub fn set_parameter(params: &mut Parameters, target: VarRef, x: f64) {
    match target {
        VarRef::YoungsModulus(i) => params.materials[i].youngs_modulus = x,
        VarRef::PoissonRatio(i) => params.materials[i].poisson_ratio = x,
        VarRef::Mass(i) => params.masses[i] = x,
        VarRef::Inertia(b, k) => params.inertias[b][k] = x,
        VarRef::ContactLaw(i) => {
            if let Some(l) = Law::from_index(x as i64) {
                params.contacts[i].law = l;
            }
        }
        VarRef::Restitution(i) => params.contacts[i].restitution = x,
        VarRef::Exponent(i) => params.contacts[i].exponent = x,
        VarRef::Damping(i) => params.contacts[i].damping = x,
        VarRef::MaxPenetration(i) => params.contacts[i].max_penetration = x,
        VarRef::MinImpactVelocity(i) => params.contacts[i].min_impact_velocity = x,
        VarRef::Stiffness(i) => params.contacts[i].stiffness = Some(x),
        VarRef::Friction(i) => params.contacts[i].friction.mu = x,
        VarRef::StaticFriction(i) => params.contacts[i].friction.mu_static = x,
        VarRef::StribeckVelocity(i) => params.contacts[i].friction.stribeck_velocity = x,
        VarRef::ViscousFriction(i) => params.contacts[i].friction.viscous = x,
        VarRef::StictionVelocity(i) => params.contacts[i].friction.stiction_velocity = x,
        VarRef::SphereRadius(i) => params.contacts[i].radius = x,
        VarRef::OtherRadius(i) => params.contacts[i].other_radius = x,
        VarRef::PlaneSize(i, k) => params.contacts[i].size[k] = x,
        VarRef::CylinderRadius(i) => params.contacts[i].cylinder_radius = x,
        VarRef::CylinderLength(i) => params.contacts[i].length = x,
        VarRef::SolverMethod => {
            if let Some(m) = Method::from_index(x as i64) {
                params.solver.method = m;
            }
        }
        VarRef::SolverRtol => params.solver.rtol = x,
        VarRef::SolverAtol => params.solver.atol = x,
        VarRef::SolverMaxStep => params.solver.max_step = x,
        VarRef::SolverMaxSteps => params.solver.max_steps = x as u64,
        VarRef::SpringStiffness(i) => params.springs[i].stiffness = x,
        VarRef::SpringDamping(i) => params.springs[i].damping = x,
        VarRef::SpringFreeLength(i) => params.springs[i].free_length = x,
        VarRef::InitialVelocity(b, k) => params.velocities[b][k] = x,
        VarRef::InitialAngularVelocity(b, k) => params.angular_velocities[b][k] = x,
        VarRef::Input(i) => params.input_start[i] = x,
        VarRef::Group(p, key) => {
            let g = &mut params.groups[p];
            match key {
                GroupKey::Law => {
                    if let Some(l) = Law::from_index(x as i64) {
                        g.law = l;
                    }
                }
                GroupKey::Restitution => g.restitution = x,
                GroupKey::Exponent => g.exponent = x,
                GroupKey::Damping => g.damping = x,
                GroupKey::MaxPenetration => g.max_penetration = Some(x),
                GroupKey::MinImpactVelocity => g.min_impact_velocity = x,
                GroupKey::Stiffness => g.stiffness = Some(x),
                GroupKey::Friction => g.friction.mu = x,
                GroupKey::StaticFriction => g.friction.mu_static = x,
                GroupKey::StribeckVelocity => g.friction.stribeck_velocity = x,
                GroupKey::ViscousFriction => g.friction.viscous = x,
                GroupKey::StictionVelocity => g.friction.stiction_velocity = x,
            }
        }
        VarRef::BodyPosition(..)
        | VarRef::BodyVelocity(..)
        | VarRef::BodyAngularVelocity(..)
        | VarRef::BodyQuaternion(..)
        | VarRef::JointQ(_)
        | VarRef::JointQd(_)
        | VarRef::ContactDelta(_)
        | VarRef::ContactDeltaDot(_)
        | VarRef::ContactForce(_)
        | VarRef::ContactActive(_)
        | VarRef::ContactImpacts(_)
        | VarRef::ContactFrictionForce(..)
        | VarRef::ContactSlipVelocity(_)
        | VarRef::EnergyKinetic
        | VarRef::EnergyPotential
        | VarRef::EnergyContact
        | VarRef::EnergyTotal
        | VarRef::EnergyDissipated
        | VarRef::EnergyInputWork
        | VarRef::DriveForce(_)
        | VarRef::SolverSteps
        | VarRef::SolverRhsEvals
        | VarRef::BodyContactForce(..)
        | VarRef::BodyContactTorque(..)
        | VarRef::GroupActive(_)
        | VarRef::GroupLargestPenetration(_) => {}
    }
}
