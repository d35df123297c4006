//! The limits and rules a scene's values keep (docs/scene.md, "Rules for names and numbers"):
//! the ranges of the solver's settings, the largest magnitudes, the rules for names, and the
//! checks of one value each that [`super::validate`] and the key tables use. Every error
//! names the file, the item and the field.

use super::*;

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

/// A time or step size in a message: as Rust writes it, except very large or small
/// magnitudes, which get an exponent (`1e300` rather than 301 digits).
pub struct Num(pub f64);

impl std::fmt::Display for Num {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let a = self.0.abs();
        if a == 0.0 || !a.is_finite() || (1e-4..1e15).contains(&a) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
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
