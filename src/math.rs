//! The transcendental functions of the engine, from one implementation on every platform (the
//! `libm` crate, a port of musl's), instead of the platform's C library: glibc and Windows'
//! msvcrt round some results differently in the last bit, and in a chaotic scene (a pile of
//! balls) a last-bit difference grows into a different trajectory. With these (and nalgebra's
//! `libm-force` feature for its own), an FMU's linux64 and win64 libraries compute the same
//! numbers, bit for bit. Square roots, absolute values and arithmetic are exact in IEEE 754 on
//! every platform and stay as they are.

/// `x` to the power `y`.
#[inline]
pub fn powf(x: f64, y: f64) -> f64 {
    libm::pow(x, y)
}

/// `x` to the integer power `n`. (`f64::powi` becomes a call of the C library's `pow` on
/// Windows but repeated multiplication on Linux, so it is routed here where `n` is not a
/// constant.)
#[inline]
pub fn powi(x: f64, n: i32) -> f64 {
    libm::pow(x, f64::from(n))
}

/// e to the power `x`.
#[inline]
pub fn exp(x: f64) -> f64 {
    libm::exp(x)
}

/// The angle of the point (`x`, `y`) from the x axis, in (-π, π].
#[inline]
pub fn atan2(y: f64, x: f64) -> f64 {
    libm::atan2(y, x)
}

/// `sqrt(x² + y²)` without overflow or underflow on the way.
#[inline]
pub fn hypot(x: f64, y: f64) -> f64 {
    libm::hypot(x, y)
}

/// (sin `x`, cos `x`).
#[inline]
pub fn sin_cos(x: f64) -> (f64, f64) {
    libm::sincos(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn agrees_with_the_platform_library_to_the_last_bits() {
        for &(x, y) in &[(0.3, 1.5), (2.0, 0.25), (1e-3, 0.2), (7.5, -0.04)] {
            assert!((powf(x, y) - x.powf(y)).abs() <= 2.0 * f64::EPSILON * x.powf(y).abs());
            assert!((atan2(y, x) - y.atan2(x)).abs() <= 2.0 * f64::EPSILON);
            assert!((hypot(x, y) - x.hypot(y)).abs() <= 2.0 * f64::EPSILON * x.hypot(y));
            assert!((exp(-y) - (-y).exp()).abs() <= 2.0 * f64::EPSILON * (-y).exp());
            let (s, c) = sin_cos(x);
            assert!((s - x.sin()).abs() <= 2.0 * f64::EPSILON && (c - x.cos()).abs() <= 2.0 * f64::EPSILON);
        }
    }
}
