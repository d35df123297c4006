//! Radau IIA of order 5 (three stages, stage order 3, L-stable, stiffly accurate), after
//! Hairer & Wanner's RADAU5 (*Solving ODEs II*, IV.8), for stiff problems with a smooth slow
//! solution, where the stage order 1 of SDIRK4 costs it accuracy (order reduction).
//!
//! - The stage increments `Zᵢ = Yᵢ − y₀` are solved together by simplified Newton with the
//!   matrix `I − h A⊗J`, `J` by forward differences. For small systems (dense linear algebra)
//!   the correction is computed, as in RADAU5, in the eigenbasis of `A⁻¹` (one real eigenvalue
//!   γ, one complex pair α ± iβ; the basis `T` is computed once per method from `A`): one real
//!   n × n system `I − (h/γ) J` (the matrix the error estimate needs anyway) and one complex
//!   n × n system `I − h/(α + iβ) J` instead of the real 3n × 3n one, about 5× fewer
//!   operations per factorisation (in-place LUs on preallocated buffers). For large systems
//!   the real 3n × 3n matrix is factored by faer's sparse LU with a coloured Jacobian
//!   ([`super::linear`]).
//! - Jacobian and LU reuse, `J = 0` after a reset, `J` and controller memory kept across a
//!   plain restart (and saved through `warm_state`), and the step-size controller are those of
//!   SDIRK4, shared in [`super::newton`].
//! - Error estimate of order 3 filtered by `(I − hγ₀J)⁻¹` (IV.8.19), refined with one more
//!   evaluation after a rejected or first step, as RADAU5 does.
//! - Dense output: the collocation polynomial through `(0, y₀)` and `(cᵢ, Yᵢ)` (order 3).
//! - Starting values of the stages: the previous step's collocation polynomial, extrapolated;
//!   for some steps after a burst of Newton failures with its stiff components replaced by
//!   those of the stage equations linearised at the step's state
//!   ([`super::warm::WarmMemory::filtered_start`]).
//! - Nothing is allocated after construction.

use super::core::StepCore;
use super::linear::{self, JacRef, LinearStats, Lu};
use super::newton::{implicit_parts, ImplicitMethod, NewtonCore};
use super::second_order::{Reduction, SecondOrder};
use super::{error_norm, OdeSystem};
use crate::linalg;
use crate::scene::Method;
use nalgebra::Complex;

const SQ6: f64 = 2.449_489_742_783_178;
/// Nodes.
const C: [f64; 3] = [(4.0 - SQ6) / 10.0, (4.0 + SQ6) / 10.0, 1.0];
/// Butcher matrix.
const A: [[f64; 3]; 3] = [
    [
        (88.0 - 7.0 * SQ6) / 360.0,
        (296.0 - 169.0 * SQ6) / 1800.0,
        (-2.0 + 3.0 * SQ6) / 225.0,
    ],
    [
        (296.0 + 169.0 * SQ6) / 1800.0,
        (88.0 + 7.0 * SQ6) / 360.0,
        (-2.0 - 3.0 * SQ6) / 225.0,
    ],
    [(16.0 - SQ6) / 36.0, (16.0 + SQ6) / 36.0, 1.0 / 9.0],
];
/// Coefficients `(−13 − 7√6)/3, (−13 + 7√6)/3, −1/3` of the embedded error formula.
const DD: [f64; 3] = [(-13.0 - 7.0 * SQ6) / 3.0, (-13.0 + 7.0 * SQ6) / 3.0, -1.0 / 3.0];

/// γ₀ = 1/λ, λ the real eigenvalue of A⁻¹: `(6 + 81^{1/3} − 9^{1/3})/30`.
fn gamma0() -> f64 {
    (6.0 + libm::cbrt(81.0) - libm::cbrt(9.0)) / 30.0
}

/// The eigenbasis of `A⁻¹`: `T⁻¹ A⁻¹ T = [[γ, 0, 0], [0, α, −β], [0, β, α]]`.
#[derive(Debug, Clone, Copy)]
struct Eigenbasis {
    t: [[f64; 3]; 3],
    t_inv: [[f64; 3]; 3],
    /// The complex eigenvalue α + iβ (γ = 1/γ₀ is the real one).
    alpha: f64,
    beta: f64,
}

/// Inverse of a 3 × 3 matrix (adjugate over determinant).
fn inverse3(m: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let c = |i: usize, j: usize| {
        let (r0, r1) = ((i + 1) % 3, (i + 2) % 3);
        let (c0, c1) = ((j + 1) % 3, (j + 2) % 3);
        m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0]
    };
    let det = m[0][0] * c(0, 0) + m[0][1] * c(0, 1) + m[0][2] * c(0, 2);
    let mut inv = [[0.0; 3]; 3];
    for (i, row) in inv.iter_mut().enumerate() {
        for (j, x) in row.iter_mut().enumerate() {
            *x = c(j, i) / det;
        }
    }
    inv
}

impl Eigenbasis {
    /// From the tableau: γ from [`gamma0`], α and β from the trace and determinant of `A⁻¹`,
    /// eigenvectors as cross products of two rows of `A⁻¹ − λI` (complex for the pair).
    fn new() -> Eigenbasis {
        let ai = inverse3(&A);
        let gamma = 1.0 / gamma0();
        let trace = ai[0][0] + ai[1][1] + ai[2][2];
        let det = 1.0 / {
            let a = &A;
            a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
                + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
        };
        let alpha = 0.5 * (trace - gamma);
        let beta = (det / gamma - alpha * alpha).sqrt();
        // complex arithmetic on (re, im)
        type C = (f64, f64);
        let mul = |a: C, b: C| (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0);
        let sub = |a: C, b: C| (a.0 - b.0, a.1 - b.1);
        let cross = |r0: [C; 3], r1: [C; 3]| {
            [
                sub(mul(r0[1], r1[2]), mul(r0[2], r1[1])),
                sub(mul(r0[2], r1[0]), mul(r0[0], r1[2])),
                sub(mul(r0[0], r1[1]), mul(r0[1], r1[0])),
            ]
        };
        let shifted = |lambda: C, i: usize| -> [C; 3] {
            [0, 1, 2].map(|j| {
                (
                    ai[i][j] - if i == j { lambda.0 } else { 0.0 },
                    if i == j { -lambda.1 } else { 0.0 },
                )
            })
        };
        let v1 = cross(shifted((gamma, 0.0), 0), shifted((gamma, 0.0), 1));
        let v = cross(shifted((alpha, beta), 0), shifted((alpha, beta), 1));
        // columns v1, Re v, −Im v
        let mut t = [[0.0; 3]; 3];
        for i in 0..3 {
            t[i] = [v1[i].0, v[i].0, -v[i].1];
        }
        Eigenbasis {
            t,
            t_inv: inverse3(&t),
            alpha,
            beta,
        }
    }
}

/// The Radau IIA 5 method (scene name `"radau5"`).
pub struct Radau5 {
    core: StepCore,
    newton: NewtonCore,
    /// Dense output of the last step (with `core.y_prev`): the stage increments `Zᵢ`, n
    /// numbers each, of the collocation polynomial.
    dense: [Vec<f64>; 3],
    /// Stage increments Z (3n, stage-major) and Newton correction.
    z: Vec<f64>,
    dz: Vec<f64>,
    /// Scratch of the filtered starting values.
    z_start: Vec<f64>,
    /// Stage values and right-hand sides.
    stage: Vec<f64>,
    fz: [Vec<f64>; 3],
    /// LU of `I − hγ₀J` (n × n, real; dense or sparse), of `I − h/(α + iβ) J` (n × n,
    /// complex, real parts then imaginary parts; the dense path only, empty on the sparse one) and of
    /// `I − hA⊗J` (3n × 3n; the sparse path only).
    lu_err: Lu,
    lu_complex: Vec<f64>,
    perm_complex: Vec<usize>,
    work_complex: Vec<f64>,
    lu_big: Option<Lu>,
    err: Vec<f64>,
    work: Vec<f64>,
    basis: Eigenbasis,
    /// The iteration matrices reduced to the velocities, for a system that declared its
    /// second-order structure (dense linear algebra only).
    reduction: Option<Box<Reduction>>,
}

impl Radau5 {
    /// A method for systems of size `n` with tolerances `rtol`, `atol` and largest step `hmax`;
    /// dense or sparse linear algebra by [`linear::sparse_for`].
    pub fn new(n: usize, rtol: f64, atol: f64, hmax: f64) -> Radau5 {
        Self::with_linear(n, rtol, atol, hmax, linear::sparse_for(n))
    }

    /// [`Radau5::new`] with the linear algebra chosen: sparse or dense.
    pub fn with_linear(n: usize, rtol: f64, atol: f64, hmax: f64, sparse: bool) -> Radau5 {
        let v = |k: usize| vec![0.0; k];
        let hmax = if hmax > 0.0 { hmax } else { f64::INFINITY };
        Radau5 {
            core: StepCore::new(n, rtol, atol, hmax),
            newton: NewtonCore::new(n, rtol, sparse),
            dense: [v(n), v(n), v(n)],
            z: v(3 * n),
            dz: v(3 * n),
            z_start: v(3 * n),
            stage: v(n),
            fz: [v(n), v(n), v(n)],
            lu_err: Lu::new(n, sparse),
            lu_complex: v(if sparse { 0 } else { 2 * n * n }),
            perm_complex: vec![0; if sparse { 0 } else { n }],
            work_complex: v(if sparse { 0 } else { 2 * n }),
            lu_big: sparse.then(|| Lu::new(3 * n, true)),
            err: v(n),
            work: v(n),
            basis: Eigenbasis::new(),
            reduction: None,
        }
    }

    /// Lagrange basis on the nodes (0, c₁, c₂, c₃) for node `i` (1..=3) at θ.
    fn basis(i: usize, th: f64) -> f64 {
        let nodes = [0.0, C[0], C[1], C[2]];
        let mut l = 1.0;
        for (k, ck) in nodes.iter().enumerate() {
            if k != i {
                l *= (th - ck) / (nodes[i] - ck);
            }
        }
        l
    }

    /// Solves the stage equations for step `h`; returns the largest contraction rate.
    fn solve_stages(&mut self, sys: &mut dyn OdeSystem, h: f64) -> Option<f64> {
        let mut solve = |x: &mut [f64]| {
            correction(
                &mut self.lu_big,
                &mut self.lu_err,
                &mut self.reduction,
                &self.basis,
                (&self.lu_complex, &self.perm_complex, &mut self.work_complex),
                x,
            )
        };
        let core = &mut self.core;
        let n = core.y.len();
        // starting values: the previous collocation polynomial, extrapolated (filtered after
        // a burst of Newton failures: `WarmMemory::filtered_start`)
        let h_prev = core.t - core.t_prev;
        if self.newton.mem.h_acc > 0.0 && h_prev > 0.0 {
            for (s, cs) in C.iter().enumerate() {
                let th = 1.0 + cs * h / h_prev;
                let l = [Self::basis(1, th), Self::basis(2, th), Self::basis(3, th)];
                for m in 0..n {
                    let u =
                        core.y_prev[m] + l[0] * self.dense[0][m] + l[1] * self.dense[1][m] + l[2] * self.dense[2][m];
                    self.z[s * n + m] = u - core.y[m];
                }
            }
            if self.newton.mem.filtered_start > 0 {
                filter_start(&mut solve, h, &core.f, &mut self.z, &mut self.dz, &mut self.z_start);
            }
        } else {
            self.z.iter_mut().for_each(|x| *x = 0.0);
        }
        let core = &mut self.core;
        let (z, dz, stage, fz) = (&mut self.z, &mut self.dz, &mut self.stage, &mut self.fz);
        self.newton.iterate(|| {
            for (s, cs) in C.iter().enumerate() {
                for m in 0..n {
                    stage[m] = core.y[m] + z[s * n + m];
                }
                sys.rhs(core.t + cs * h, stage, &mut fz[s]);
            }
            core.stats.rhs_evals += 3;
            // residual −Z + h (A⊗I) F
            for (s, a_row) in A.iter().enumerate() {
                for m in 0..n {
                    let hf = h * (a_row[0] * fz[0][m] + a_row[1] * fz[1][m] + a_row[2] * fz[2][m]);
                    dz[s * n + m] = hf - z[s * n + m];
                }
            }
            solve(dz);
            let mut sum = 0.0;
            let mut at_roundoff = true;
            for s in 0..3 {
                for m in 0..n {
                    let d = dz[s * n + m];
                    let sc = core.atol + core.rtol * core.y[m].abs();
                    sum += (d / sc) * (d / sc);
                    let zi = z[s * n + m] + d;
                    at_roundoff &= d.abs() <= 8.0 * f64::EPSILON * (core.y[m] + zi).abs();
                    z[s * n + m] = zi;
                }
            }
            ((sum / (3 * n).max(1) as f64).sqrt(), at_roundoff)
        })
    }

    /// Filtered error estimate (IV.8.19) in `self.err`; its weighted norm.
    fn error_estimate(&mut self, sys: &mut dyn OdeSystem, h: f64, refine: bool) -> f64 {
        let core = &mut self.core;
        let n = core.y.len();
        let g0 = gamma0();
        // work = γ₀ Σ ddᵢ Zᵢ (the h·f₀ term added below)
        for m in 0..n {
            self.work[m] = g0 * (DD[0] * self.z[m] + DD[1] * self.z[n + m] + DD[2] * self.z[2 * n + m]);
            self.err[m] = self.work[m] + g0 * h * core.f[m];
        }
        solve_real(&mut self.lu_err, &mut self.reduction, &mut self.err);
        for m in 0..n {
            self.stage[m] = core.y[m] + self.z[2 * n + m];
        }
        let mut e = error_norm(&self.err, &core.y, &self.stage, core.rtol, core.atol);
        if refine && e >= 1.0 {
            // RADAU5: replace f(y₀) by f(y₀ + err) and filter again
            for m in 0..n {
                self.stage[m] = core.y[m] + self.err[m];
            }
            sys.rhs(core.t, &self.stage, &mut self.fz[0]);
            core.stats.rhs_evals += 1;
            for m in 0..n {
                self.err[m] = self.work[m] + g0 * h * self.fz[0][m];
            }
            solve_real(&mut self.lu_err, &mut self.reduction, &mut self.err);
            for m in 0..n {
                self.stage[m] = core.y[m] + self.z[2 * n + m];
            }
            e = error_norm(&self.err, &core.y, &self.stage, core.rtol, core.atol);
        }
        e
    }
}

/// Filters the extrapolated starting values `Z_ex` in `z` for step `h` (no evaluation, two
/// corrections with the factors in use, `solve`; `f0 = f(y₀)`; `lin` and `w` are scratch):
/// with `M = I − hA⊗J` and `Z_lin = M⁻¹ h(c⊗f0)`, the solution of the stage equations
/// linearised at the step's state, `Z = Z_lin − M⁻¹(Z_lin − Z_ex)`. On a mode of `hA⊗J` with
/// eigenvalue μ the weight of `Z_ex` is `1/(1 − μ)`: the non-stiff components (|μ| ≪ 1) keep
/// the extrapolation (to O(μ)), the stiff ones (|μ| ≫ 1) are those of `Z_lin`.
fn filter_start(solve: &mut impl FnMut(&mut [f64]), h: f64, f0: &[f64], z: &mut [f64], lin: &mut [f64], w: &mut [f64]) {
    let n = f0.len();
    for (s, cs) in C.iter().enumerate() {
        for m in 0..n {
            lin[s * n + m] = h * cs * f0[m];
        }
    }
    solve(lin);
    for ((w, l), ex) in w.iter_mut().zip(&*lin).zip(&*z) {
        *w = l - ex;
    }
    solve(w);
    for ((z, l), w) in z.iter_mut().zip(&*lin).zip(&*w) {
        *z = l - w;
    }
}

/// The simplified Newton correction `(I − hA⊗J)⁻¹ dz` in place, from the factors of
/// [`Radau5::factor`] (sparse: the 3n × 3n LU; dense: the real and complex systems in the
/// eigenbasis of `A⁻¹`).
fn correction(
    lu_big: &mut Option<Lu>,
    lu_err: &mut Lu,
    reduction: &mut Option<Box<Reduction>>,
    basis: &Eigenbasis,
    (lu_complex, perm_complex, work_complex): (&[f64], &[usize], &mut [f64]),
    dz: &mut [f64],
) {
    let n = dz.len() / 3;
    if let Some(big) = lu_big.as_mut() {
        big.solve(dz);
    } else {
        // the correction (I − hA⊗J)⁻¹ dz in the eigenbasis: W = (T⁻¹⊗I) dz, then the
        // real system for W₁ and the complex one for W₂ + iW₃ (both scaled so that
        // their right-hand sides are W itself), then dz = (T⊗I) W
        let (ti, t) = (&basis.t_inv, &basis.t);
        for m in 0..n {
            let r = [dz[m], dz[n + m], dz[2 * n + m]];
            for (s, row) in ti.iter().enumerate() {
                dz[s * n + m] = row[0] * r[0] + row[1] * r[1] + row[2] * r[2];
            }
        }
        let (w1, w23) = dz.split_at_mut(n);
        let (w2, w3) = w23.split_at_mut(n);
        match reduction.as_deref_mut().filter(|r| r.active) {
            Some(r) => {
                r.solve_real(w1);
                r.solve_complex(w2, w3);
            }
            None => {
                lu_err.solve(w1);
                linalg::lu_solve_complex(lu_complex, n, perm_complex, w2, w3, work_complex);
            }
        }
        for m in 0..n {
            let w = [dz[m], dz[n + m], dz[2 * n + m]];
            for (s, row) in t.iter().enumerate() {
                dz[s * n + m] = row[0] * w[0] + row[1] * w[1] + row[2] * w[2];
            }
        }
    }
}

/// Solves `(I − hγ₀J) x = x` in place: reduced when the last factorisation was.
fn solve_real(lu: &mut Lu, reduction: &mut Option<Box<Reduction>>, x: &mut [f64]) {
    match reduction.as_deref_mut().filter(|r| r.active) {
        Some(r) => r.solve_real(x),
        None => lu.solve(x),
    }
}

impl ImplicitMethod for Radau5 {
    implicit_parts!(Method::Radau5, order 5, scratch fz);

    /// `I − hγ₀J` (real) and `I − h/(α + iβ) J` (complex).
    fn factor(&mut self, h: f64) -> bool {
        let n = self.core.y.len();
        let (alpha, beta) = (self.basis.alpha, self.basis.beta);
        let (err, big) = (&mut self.lu_err, &mut self.lu_big);
        let (lu_complex, perm_complex) = (&mut self.lu_complex, &mut self.perm_complex);
        let reduction = &mut self.reduction;
        self.newton.factor(h, |jac| match (jac, big) {
            (JacRef::Dense(dense), None) => {
                // h/(α + iβ) = h (α − iβ)/(α² + β²)
                let d = alpha * alpha + beta * beta;
                let (cr, ci) = (h * alpha / d, -h * beta / d);
                if reduction
                    .as_deref_mut()
                    .is_some_and(|r| r.factor(dense, n, h * gamma0(), Complex::new(cr, ci)))
                {
                    return true;
                }
                let (lu_re, lu_im) = lu_complex.split_at_mut(n * n);
                for ((r, i), j) in lu_re.iter_mut().zip(lu_im.iter_mut()).zip(dense) {
                    *r = -cr * j;
                    *i = -ci * j;
                }
                for i in 0..n {
                    lu_re[i * n + i] += 1.0;
                }
                err.factor_shifted(jac, h * gamma0()) && linalg::lu_in_place_complex(lu_complex, n, perm_complex)
            }
            (_, Some(big)) => big.factor_kron(jac, h, &A) && err.factor_shifted(jac, h * gamma0()),
            (JacRef::Sparse(_), None) => unreachable!("a sparse Jacobian on the dense path"),
        })
    }

    /// On the sparse path (from [`super::linear::SPARSE_MIN_N`] states on: piles of free
    /// bodies) as many evaluations as the system has states: in `pile_of_balls` at rtol 1e-3
    /// (callgrind), one factorisation of `I − hA⊗J` and `I − hγ₀J` of the merged island (about
    /// 305 states) took 4.1 M instructions and one evaluation of its right-hand side 13.8 k
    /// (the fill of a contact graph in space grows the factorisation faster than the
    /// evaluation). On the dense path left out: a factorisation there costs about two
    /// evaluations (the rail vehicle), and [`super::auto::COST_RATIO`] was set without them.
    fn factorisation_evaluations(&self) -> f64 {
        if self.lu_big.is_some() {
            self.core.y.len() as f64
        } else {
            0.0
        }
    }

    fn use_second_order(&mut self, s: &SecondOrder) {
        let n = self.core.y.len();
        if self.lu_big.is_none() && matches!(self.lu_err, Lu::Dense { .. }) && s.nq + s.nv <= n {
            self.reduction = Some(Box::new(Reduction::new(s, n)));
        }
    }

    fn linear_stats(&self) -> LinearStats {
        let (f1, a1) = self.lu_big.as_ref().map_or((0, 0), Lu::sparse_counts);
        let (f2, a2) = self.lu_err.sparse_counts();
        LinearStats {
            sparse_factorisations: f1 + f2,
            analyses: a1 + a2,
            ..self.newton.linear_stats()
        }
    }

    fn attempt(&mut self, sys: &mut dyn OdeSystem, h: f64, refine: bool) -> Option<(f64, f64)> {
        if !self.factor(h) {
            return None;
        }
        let theta = self.solve_stages(sys, h)?;
        let err = self.error_estimate(sys, h, refine);
        Some((err, theta))
    }

    fn accept(&mut self, sys: &mut dyn OdeSystem, _h: f64, t_new: f64) {
        let core = &mut self.core;
        let n = core.y.len();
        core.y_prev.copy_from_slice(&core.y);
        for (s, zs) in self.dense.iter_mut().enumerate() {
            zs.copy_from_slice(&self.z[s * n..(s + 1) * n]);
        }
        for m in 0..n {
            core.y[m] += self.z[2 * n + m];
        }
        core.advance(t_new);
        // f at the new state (the last stage's f is only converged to the Newton tolerance)
        sys.rhs(core.t, &core.y, &mut core.f);
        core.stats.rhs_evals += 1;
    }

    /// The collocation polynomial (RADAU5's dense output: through the state at the step's start
    /// and its three stages; O(h⁴) over the step). A two-step Hermite interpolant through the
    /// states and `h·f` at the starts of the last two steps and at the end was one order more
    /// accurate on smooth components, but on a stiff one `h·f` carries `hλ` times the state's
    /// error: the rail vehicle's friction forces (wheel spin, λ ≈ −6,100 s⁻¹) came out 4 kN off
    /// their range of 516 N at communication points, against 53 N here.
    fn dense_output(&self, t: f64, out: &mut [f64]) {
        let core = &self.core;
        let y0 = &core.y_prev;
        let [z0, z1, z2] = &self.dense;
        core.interpolate(t, out, |th, _h, out| {
            let l = [Self::basis(1, th), Self::basis(2, th), Self::basis(3, th)];
            for (m, o) in out.iter_mut().enumerate() {
                *o = y0[m] + l[0] * z0[m] + l[1] * z1[m] + l[2] * z2[m];
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::super::dopri5::Dopri5;
    use super::super::sdirk::Sdirk;
    use super::super::test_problems::*;
    use super::super::Integrator;
    use super::*;

    #[test]
    fn tableau_is_radau_iia() {
        // B(5): Σ bᵢ cᵢ^{k−1} = 1/k; C(3): Σⱼ aᵢⱼ cⱼ^{k−1} = cᵢᵏ/k
        for k in 1..=5 {
            let s: f64 = (0..3).map(|i| A[2][i] * C[i].powi(k - 1)).sum();
            assert!((s - 1.0 / k as f64).abs() < 1e-14, "B({k}): {s}");
        }
        for i in 0..3 {
            for k in 1..=3 {
                let s: f64 = (0..3).map(|j| A[i][j] * C[j].powi(k - 1)).sum();
                assert!((s - C[i].powi(k) / k as f64).abs() < 1e-14, "C({k}) row {i}");
            }
        }
        // γ₀ is the inverse of a real eigenvalue of A⁻¹, i.e. an eigenvalue of A: det(A − γ₀I) = 0
        let g = gamma0();
        let m = |i: usize, j: usize| A[i][j] - if i == j { g } else { 0.0 };
        let det = m(0, 0) * (m(1, 1) * m(2, 2) - m(1, 2) * m(2, 1)) - m(0, 1) * (m(1, 0) * m(2, 2) - m(1, 2) * m(2, 0))
            + m(0, 2) * (m(1, 0) * m(2, 1) - m(1, 1) * m(2, 0));
        assert!(det.abs() < 1e-14, "det {det}");
        // the embedded formula is consistent: γ₀(1 + Σ ddᵢ cᵢ) = 0
        let s: f64 = (0..3).map(|i| DD[i] * C[i]).sum();
        assert!((1.0 + s).abs() < 1e-14);
    }

    #[test]
    fn converges_with_order_five() {
        assert_fixed_step_order("radau5", Radau5::new, 5.0);
    }

    #[test]
    fn dense_output_and_error_estimate_have_the_expected_local_orders() {
        // collocation polynomial: O(h⁴) over the step; error estimate of an order-3 method: O(h⁴)
        let run = |h: f64| smooth_one_step(Radau5::new, 1.0, h);
        let ((d1, s1), (d2, s2), (d3, s3)) = (run(0.1), run(0.05), run(0.025));
        assert_order("dense output", 4.0, [d1, d2, d3]);
        assert_order("error estimate", 4.0, [s1, s2, s3]);
    }

    #[test]
    fn adaptive_run_meets_the_tolerance() {
        let y0 = Growth::exact(0.0);
        for tol in [1e-5, 1e-8] {
            let mut m = Radau5::new(3, tol, tol, f64::INFINITY);
            let y = run(&mut m, &mut Growth, 0.0, &y0, 2.0);
            let e = max_diff(&y, &Growth::exact(2.0)) / 2f64.exp();
            assert!(e < 100.0 * tol, "tol {tol:e}: relative error {e:e}");
        }
    }

    #[test]
    fn stiff_problems_take_far_fewer_steps_than_dopri5_and_sdirk4() {
        let lambda = -1e5;
        let tol = 1e-6;
        let mut imp = Radau5::new(1, tol, tol, f64::INFINITY);
        let y = run(&mut imp, &mut ProtheroRobinson { lambda }, 0.0, &[0.0], 10.0);
        assert!(
            (y[0] - 10f64.sin()).abs() < 10.0 * tol,
            "error {:e} {:?}",
            (y[0] - 10f64.sin()).abs(),
            imp.stats()
        );
        let mut exp = Dopri5::new(1, tol, tol, f64::INFINITY);
        run(&mut exp, &mut ProtheroRobinson { lambda }, 0.0, &[0.0], 10.0);
        assert!(
            exp.stats().steps > 1000 * imp.stats().steps,
            "{:?} {:?}",
            imp.stats(),
            exp.stats()
        );
        // a stiff spring on a moving support: stage order 3 avoids SDIRK4's order reduction
        struct Support;
        impl OdeSystem for Support {
            fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) {
                let (w, om) = (2.0 * std::f64::consts::PI * 5.0, 1e4);
                let (s, sd) = (1e-3 * (w * t).sin(), 1e-3 * w * (w * t).cos());
                dy[0] = y[1];
                dy[1] = -om * om * (y[0] - s) - 2.0 * om * (y[1] - sd) - 9.81;
            }
        }
        let tol = 1e-8;
        let mut reference = Radau5::new(2, 1e-12, 1e-12, f64::INFINITY);
        let y_ref = run(&mut reference, &mut Support, 0.0, &[0.0, -1.0], 1.0);
        let mut check = Dopri5::new(2, 1e-12, 1e-12, f64::INFINITY);
        let y_chk = run(&mut check, &mut Support, 0.0, &[0.0, -1.0], 1.0);
        assert!(max_diff(&y_ref, &y_chk) < 1e-9, "{y_ref:?} vs {y_chk:?}");
        let mut ra = Radau5::new(2, tol, tol, f64::INFINITY);
        let y_ra = run(&mut ra, &mut Support, 0.0, &[0.0, -1.0], 1.0);
        let mut sd = Sdirk::new(2, tol, tol, f64::INFINITY);
        run(&mut sd, &mut Support, 0.0, &[0.0, -1.0], 1.0);
        assert!(
            max_diff(&y_ra, &y_ref) < 10.0 * tol,
            "error {:e}",
            max_diff(&y_ra, &y_ref)
        );
        assert!(
            sd.stats().rhs_evals > 5 * ra.stats().rhs_evals,
            "radau5 {:?} sdirk4 {:?}",
            ra.stats(),
            sd.stats()
        );
    }
}
