//! The table of a scene's user-visible variables: parameters, inputs and outputs, with the
//! names fixed by `README.md` ("FMU variables"). It is a pure function of the scene; the FMI layer and the
//! exporter read it, the simulation answers get/set by index into it.
//!
//! The value reference of a variable is its index in [`VariableTable::vars`].

use crate::compile::Parameters;
use crate::scene::{JointType, Law, Method, Scene, ATOL_RANGE, MIN_MAX_STEP, RTOL_RANGE};

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
    /// Changes at events only (Integer/Boolean outputs).
    Discrete,
    /// Real inputs and outputs.
    Continuous,
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
    /// contact index: law
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
    /// solver.method
    SolverMethod,
    /// solver.rtol
    SolverRtol,
    /// solver.atol
    SolverAtol,
    /// solver.max_step
    SolverMaxStep,
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
    /// solver.steps
    SolverSteps,
    /// solver.rhs_evals
    SolverRhsEvals,
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
    /// Description.
    pub description: String,
    /// Allowed range of a parameter, checked when initialisation ends (inclusive unless the
    /// exclusive flags say otherwise).
    pub range: Option<Range>,
    /// What it refers to.
    pub target: VarRef,
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

/// The units used by variables, for UnitDefinitions: (name, SI base-unit exponents
/// kg, m, s in that order).
pub const UNITS: &[(&str, [i32; 3])] = &[
    ("m", [0, 1, 0]),
    ("m/s", [0, 1, -1]),
    ("rad/s", [0, 0, -1]),
    ("kg", [1, 0, 0]),
    ("N", [1, 1, -2]),
    ("J", [1, 2, -2]),
    ("Pa", [1, -1, -2]),
    ("s", [0, 0, 1]),
    ("N.s/m", [1, 0, -1]),
];

/// All variables of a scene, in value-reference order.
#[derive(Debug, Clone)]
pub struct VariableTable {
    /// The variables; index = value reference.
    pub vars: Vec<Variable>,
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
            description: description.to_string(),
            range: Some(range),
            target,
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
                "mass",
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
                description: "contact law".into(),
                range: Some(Range {
                    min: 1.0,
                    min_exclusive: false,
                    max: 6.0,
                    max_exclusive: false,
                }),
                target: VarRef::ContactLaw(i),
            });
            v.push(param(
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
                "coefficient of restitution",
            ));
            v.push(param(
                format!("{}.exponent", c.name),
                c.exponent.unwrap_or(1.5),
                None,
                Range::open_above(1.0, false),
                VarRef::Exponent(i),
                "force exponent n",
            ));
            v.push(param(
                format!("{}.damping", c.name),
                c.damping.unwrap_or(0.0),
                Some("N.s/m"),
                nonneg,
                VarRef::Damping(i),
                "Kelvin-Voigt damping [N s/m]",
            ));
            v.push(param(
                format!("{}.max_penetration", c.name),
                c.max_penetration_or_default(),
                Some("m"),
                pos,
                VarRef::MaxPenetration(i),
                "largest admissible penetration",
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
                variability: Variability::Fixed,
                start: c.stiffness,
                unit: None,
                description: "contact stiffness K [N/m^n]".into(),
                range: c.stiffness.map(|_| pos),
                target: VarRef::Stiffness(i),
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
            description: "integration method".into(),
            range: Some(Range {
                min: 1.0,
                min_exclusive: false,
                max: Method::ALL.len() as f64,
                max_exclusive: false,
            }),
            target: VarRef::SolverMethod,
        });
        v.push(param(
            "solver.rtol".into(),
            s.rtol,
            None,
            Range::closed(RTOL_RANGE),
            VarRef::SolverRtol,
            "relative tolerance",
        ));
        v.push(param(
            "solver.atol".into(),
            s.atol,
            None,
            Range::closed(ATOL_RANGE),
            VarRef::SolverAtol,
            "absolute tolerance",
        ));
        v.push(param(
            "solver.max_step".into(),
            s.max_step,
            Some("s"),
            Range::open_above(MIN_MAX_STEP, false),
            VarRef::SolverMaxStep,
            "largest internal step",
        ));
        for (i, inp) in scene.input.iter().enumerate() {
            v.push(Variable {
                name: inp.name.clone(),
                vtype: VarType::Real,
                causality: Causality::Input,
                variability: Variability::Continuous,
                start: Some(inp.start),
                unit: None,
                description: format!("{:?} input", inp.kind).to_lowercase(),
                range: None,
                target: VarRef::Input(i),
            });
        }
        let out = |name: String, vtype: VarType, unit, target, description: &str| Variable {
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
            description: description.to_string(),
            range: None,
            target,
        };
        for (i, b) in scene.body.iter().enumerate() {
            for k in 0..3 {
                v.push(out(
                    format!("{}.r[{}]", b.name, k + 1),
                    VarType::Real,
                    Some("m"),
                    VarRef::BodyPosition(i, k),
                    "centre-of-mass position",
                ));
            }
            for k in 0..3 {
                v.push(out(
                    format!("{}.v[{}]", b.name, k + 1),
                    VarType::Real,
                    Some("m/s"),
                    VarRef::BodyVelocity(i, k),
                    "centre-of-mass velocity",
                ));
            }
            for k in 0..3 {
                v.push(out(
                    format!("{}.w[{}]", b.name, k + 1),
                    VarType::Real,
                    Some("rad/s"),
                    VarRef::BodyAngularVelocity(i, k),
                    "angular velocity (world)",
                ));
            }
            for k in 0..4 {
                v.push(out(
                    format!("{}.q[{}]", b.name, k + 1),
                    VarType::Real,
                    None,
                    VarRef::BodyQuaternion(i, k),
                    "orientation quaternion (w, x, y, z)",
                ));
            }
        }
        for (i, j) in scene.joint.iter().enumerate() {
            if matches!(j.kind, JointType::Revolute | JointType::Prismatic) {
                v.push(out(
                    format!("{}.q", j.name),
                    VarType::Real,
                    None,
                    VarRef::JointQ(i),
                    "joint coordinate [m or rad]",
                ));
                v.push(out(
                    format!("{}.qd", j.name),
                    VarType::Real,
                    None,
                    VarRef::JointQd(i),
                    "joint rate [m/s or rad/s]",
                ));
            }
        }
        for (i, c) in scene.contact.iter().enumerate() {
            v.push(out(
                format!("{}.delta", c.name),
                VarType::Real,
                Some("m"),
                VarRef::ContactDelta(i),
                "penetration (0 when apart)",
            ));
            v.push(out(
                format!("{}.delta_dot", c.name),
                VarType::Real,
                Some("m/s"),
                VarRef::ContactDeltaDot(i),
                "penetration rate",
            ));
            v.push(out(
                format!("{}.force", c.name),
                VarType::Real,
                Some("N"),
                VarRef::ContactForce(i),
                "normal force magnitude",
            ));
            v.push(out(
                format!("{}.active", c.name),
                VarType::Boolean,
                None,
                VarRef::ContactActive(i),
                "in contact",
            ));
            v.push(out(
                format!("{}.impacts", c.name),
                VarType::Integer,
                None,
                VarRef::ContactImpacts(i),
                "impacts resolved so far (impulse law)",
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
            ("energy.total", VarRef::EnergyTotal, "kinetic + potential + contact"),
            (
                "energy.dissipated",
                VarRef::EnergyDissipated,
                "work removed since initialisation",
            ),
        ] {
            v.push(out(name.into(), VarType::Real, Some("J"), t, d));
        }
        v.push(out(
            "solver.steps".into(),
            VarType::Integer,
            None,
            VarRef::SolverSteps,
            "accepted integration steps since initialisation",
        ));
        v.push(out(
            "solver.rhs_evals".into(),
            VarType::Integer,
            None,
            VarRef::SolverRhsEvals,
            "right-hand-side evaluations since initialisation",
        ));
        VariableTable { vars: v }
    }

    /// Index of a variable by name.
    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.vars.iter().position(|v| v.name == name)
    }
}

/// Writes the value `x` of the parameter (or input start value) `target` into `params`;
/// every other variable is not a parameter and changes nothing.
pub fn set_parameter(params: &mut Parameters, target: VarRef, x: f64) {
    match target {
        VarRef::YoungsModulus(i) => params.materials[i].youngs_modulus = x,
        VarRef::PoissonRatio(i) => params.materials[i].poisson_ratio = x,
        VarRef::Mass(i) => params.masses[i] = x,
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
        VarRef::SolverMethod => {
            if let Some(m) = Method::from_index(x as i64) {
                params.solver.method = m;
            }
        }
        VarRef::SolverRtol => params.solver.rtol = x,
        VarRef::SolverAtol => params.solver.atol = x,
        VarRef::SolverMaxStep => params.solver.max_step = x,
        VarRef::Input(i) => params.input_start[i] = x,
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
        | VarRef::EnergyKinetic
        | VarRef::EnergyPotential
        | VarRef::EnergyContact
        | VarRef::EnergyTotal
        | VarRef::EnergyDissipated
        | VarRef::SolverSteps
        | VarRef::SolverRhsEvals => {}
    }
}
