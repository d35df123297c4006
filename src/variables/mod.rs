//! The table of a scene's user-visible variables: parameters, inputs and outputs, with the
//! names fixed by `README.md` ("FMU variables"). It is a pure function of the scene; the FMI layer and the
//! exporter read it, the simulation answers get/set by index into it.
//!
//! The value reference of a variable is its index in [`VariableTable::vars`].

use crate::compile::Parameters;
use crate::model::contact::LawConstants;
use crate::scene::{
    ContactType, InputType, JointType, Law, Method, Scene, ATOL_RANGE, MAX_MAGNITUDE, MAX_STEPS_LIMIT,
    MIN_MAX_PENETRATION, RTOL_RANGE, RUNAWAY_SPEED,
};

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

named_enum! {
    /// FMI causality, by the name FMI gives it (`causality` attribute).
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    pub enum Causality {
        /// Set by the user before initialisation.
        Parameter => "parameter",
        /// Computed from parameters at initialisation.
        CalculatedParameter => "calculatedParameter",
        /// Set by the host at any communication point.
        Input => "input",
        /// Computed.
        Output => "output",
    }
}

named_enum! {
    /// FMI variability, by the name FMI gives it (`variability` attribute).
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    pub enum Variability {
        /// Fixed after initialisation.
        Fixed => "fixed",
        /// A parameter that may also change between communication points after initialisation
        /// (it takes effect from the next step on).
        Tunable => "tunable",
        /// Changes at events only (Integer/Boolean outputs).
        Discrete => "discrete",
        /// Real inputs and outputs.
        Continuous => "continuous",
    }
}

/// What a variable refers to inside the simulation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum VarRef {
    /// material index: E
    YoungsModulus(usize),
    /// material index: ν
    PoissonRatio(usize),
    /// body index (scene order): mass
    Mass(usize),
    /// body index, component 0..3: principal moment of inertia
    Inertia(usize, usize),
    /// contact index, key: a law constant (`<contact>.law` and its Integer twin
    /// `<contact>.law_index`, `<contact>.restitution`, …; `<contact>.stiffness` is a calculated
    /// parameter where the materials give it)
    Contact(usize, LawKey),
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
    /// solver.events
    SolverEvents,
    /// contact group pair index, key: a law constant of every contact of the pair
    Group(usize, LawKey),
    /// body index, component: total contact force on the body, world frame
    BodyContactForce(usize, usize),
    /// body index, component: total contact torque about the centre of mass, world frame
    BodyContactTorque(usize, usize),
    /// contact group pair index: Integer number of contacts in contact
    GroupActive(usize),
    /// contact group pair index: largest penetration of its contacts
    GroupLargestPenetration(usize),
}

/// The law constants of a contact or of a contact group pair that are FMU parameters
/// (`<contact>.<key>`, `<pair>.<key>`: the law keys of a `[[contact]]`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LawKey {
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
    pub(crate) fn open_above(min: f64, min_exclusive: bool) -> Range {
        Range {
            min,
            min_exclusive,
            max: f64::INFINITY,
            max_exclusive: false,
        }
    }
    pub(crate) fn closed([min, max]: [f64; 2]) -> Range {
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
    /// Human-readable form, e.g. `(0, inf)`, `[0, 0.5)` or `[1e-14, 0.01]` (an infinite end is
    /// open: [`Range::contains`] takes finite values only).
    pub fn describe(&self) -> String {
        let num = crate::scene::short;
        format!(
            "{}{}, {}{}",
            if self.min_exclusive || self.min.is_infinite() {
                "("
            } else {
                "["
            },
            num(self.min),
            num(self.max),
            if self.max_exclusive || self.max.is_infinite() {
                ")"
            } else {
                "]"
            }
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

impl Unit {
    /// The unit `name` with the base-unit exponents `base` and the display units `display`.
    const fn new(name: &'static str, base: [i32; 4], display: &'static [(&'static str, f64)]) -> Unit {
        Unit { name, base, display }
    }
}

/// The units the variables use, for UnitDefinitions, with the display units engineers read
/// (mm, km/h, deg, rpm).
pub const UNITS: &[Unit] = &[
    Unit::new("m", [0, 1, 0, 0], &[("mm", 1e3)]),
    Unit::new("m/s", [0, 1, -1, 0], &[("km/h", 3.6), ("mm/s", 1e3)]),
    Unit::new("rad", [0, 0, 0, 1], &[("deg", 180.0 / std::f64::consts::PI)]),
    Unit::new(
        "rad/s",
        [0, 0, -1, 1],
        &[
            ("deg/s", 180.0 / std::f64::consts::PI),
            ("rpm", 30.0 / std::f64::consts::PI),
        ],
    ),
    Unit::new("m/s2", [0, 1, -2, 0], &[]),
    Unit::new("rad/s2", [0, 0, -2, 1], &[("deg/s2", 180.0 / std::f64::consts::PI)]),
    Unit::new("kg", [1, 0, 0, 0], &[]),
    Unit::new("N", [1, 1, -2, 0], &[("kN", 1e-3)]),
    Unit::new("N.m", [1, 2, -2, 0], &[]),
    Unit::new("J", [1, 2, -2, 0], &[]),
    Unit::new("Pa", [1, -1, -2, 0], &[("GPa", 1e-9)]),
    Unit::new("s", [0, 0, 1, 0], &[("ms", 1e3)]),
    Unit::new("N.s/m", [1, 0, -1, 0], &[]),
    Unit::new("N/m", [1, 0, -2, 0], &[]),
    Unit::new("s/m", [0, -1, 1, 0], &[]),
    Unit::new("kg.m2", [1, 2, 0, 0], &[]),
];

mod groups;
mod law;
use law::set_law_value;
mod motion;
mod table;

/// The units of a 1-DOF joint's coordinate, rate and acceleration: rad, rad/s and rad/s2
/// (revolute), m, m/s and m/s2 (prismatic).
fn joint_units(kind: JointType) -> [&'static str; 3] {
    if kind == JointType::Revolute {
        ["rad", "rad/s", "rad/s2"]
    } else {
        ["m", "m/s", "m/s2"]
    }
}

/// `x`, `y`, `z` for the components 0, 1, 2 of a world vector.
const AXES: [&str; 3] = ["x", "y", "z"];

/// The reference of component `k` of item `i` (e.g. [`VarRef::BodyPosition`]).
type ComponentRef = fn(usize, usize) -> VarRef;

/// The Real outputs `<owner>.<key>[1]` … `[3]` of a vector in world axes: component `k` reads
/// `target(k)` and is described as `<what>, world <axis>`.
fn world_vector(
    owner: &str,
    key: &str,
    unit: &'static str,
    target: impl Fn(usize) -> VarRef,
    what: &str,
    depends_on_inputs: bool,
) -> [Variable; 3] {
    std::array::from_fn(|k| {
        output_variable(
            format!("{owner}.{key}[{}]", k + 1),
            VarType::Real,
            Some(unit),
            target(k),
            format!("{what}, world {}", AXES[k]),
            depends_on_inputs,
        )
    })
}

/// All variables of a scene, in value-reference order.
#[derive(Debug, Clone)]
pub struct VariableTable {
    /// The variables; index = value reference.
    pub vars: Vec<Variable>,
    /// By value reference, for the outputs read from the state: the inputs that move them at
    /// once when set (`<drive>.q`, `<drive>.qd` of the driven joints whose bodies they
    /// depend on; empty in a scene without `joint_motion` inputs).
    pub moved_by: Vec<Vec<usize>>,
}

impl VariableTable {
    /// Builds the table from a (validated) scene.
    pub fn from_scene(scene: &Scene) -> VariableTable {
        let mut v = Vec::new();
        table::parameters(scene, &mut v);
        table::solver(scene, &mut v);
        table::inputs(scene, &mut v);
        table::outputs(scene, &mut v);
        table::later_parameters(scene, &mut v);
        groups::group_variables(scene, &mut v);
        motion::motion_outputs(scene, &mut v);
        table::later_outputs(&mut v);
        let moved_by = motion::moved_by(scene, &v);
        VariableTable { vars: v, moved_by }
    }

    /// Index of a variable by name.
    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.vars.iter().position(|v| v.name == name)
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

/// A Real parameter, fixed after initialisation, checked against `range`.
fn param(
    name: String,
    start: f64,
    unit: Option<&'static str>,
    range: Range,
    target: VarRef,
    description: &str,
) -> Variable {
    Variable {
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
    }
}

/// `var`, tunable: contact-law constants may change between communication points (docs/fmi.md).
fn tunable(mut var: Variable) -> Variable {
    var.variability = Variability::Tunable;
    var
}

/// An enumeration parameter of type `enum_type` (its items numbered from 1), fixed after
/// initialisation, starting at item `start`.
fn enum_param(name: String, enum_type: EnumType, start: i64, target: VarRef, description: String) -> Variable {
    Variable {
        name,
        vtype: VarType::Enumeration(enum_type),
        causality: Causality::Parameter,
        variability: Variability::Fixed,
        start: Some(start as f64),
        unit: None,
        display_unit: None,
        description,
        range: Some(Range::closed([1.0, enum_type.items().len() as f64])),
        target,
        depends_on_inputs: false,
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
        range: Some(Range::closed([0.0, e.items().len() as f64])),
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
        VarRef::Contact(i, key) => set_law_value(&mut params.contacts[i].law, key, x),
        VarRef::SphereRadius(i) => params.contacts[i].radius = x,
        VarRef::OtherRadius(i) => params.contacts[i].other_radius = x,
        VarRef::PlaneSize(i, k) => params.contacts[i].size[k] = x,
        VarRef::CylinderRadius(i) => params.contacts[i].cylinder_radius = x,
        VarRef::CylinderLength(i) => params.contacts[i].length = x,
        VarRef::SolverMethod => {
            if let Some(m) = Method::from_value(x as i64) {
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
        VarRef::Group(p, key) => set_law_value(&mut params.groups[p], key, x),
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
        | VarRef::SolverEvents
        | VarRef::BodyContactForce(..)
        | VarRef::BodyContactTorque(..)
        | VarRef::GroupActive(_)
        | VarRef::GroupLargestPenetration(_) => {}
    }
}
