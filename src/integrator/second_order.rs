//! The iteration matrices of a mechanical system, reduced to its velocities.
//!
//! A multibody state is `y = (q, v, e)`: positions, velocities and integrals that nothing
//! depends on (the dissipated energy). The position rates of a joint depend on its own `q`
//! and `v` only (`q̇ = v`, or quaternion rates), so the Jacobian has the blocks
//!
//! ```text
//!     | Jqq  T   0 |      Jqq, T block-diagonal by joint
//! J = | Aq   Av  0 |      Aq, Av: the accelerations' derivatives (dense)
//!     | Eq   Ev  0 |      Eq, Ev: the integrals' rates
//! ```
//!
//! and `(I − cJ) x = b` is solved through the Schur complement on the velocities (Hairer and
//! Wanner's RADAU5 does the same for `q̇ = v`): with `Q = I − c Jqq` (one small block per
//! joint, the identity for revolute and prismatic joints) and `P = Q⁻¹ T`,
//!
//! ```text
//! S = I − c Av − c² Aq P,   S xv = bv + c Aq Q⁻¹ bq,   xq = Q⁻¹ bq + c P xv,
//! xe = be + c (Eq xq + Ev xv).
//! ```
//!
//! The factorisation works on an `nv × nv` matrix instead of `n × n` (the rail vehicle: 18
//! against 38, 9× fewer operations) and a solve costs about half as much. It is exact: the
//! same linear system, solved another way (results differ by rounding). [`SecondOrder::holds`]
//! checks the structure on each Jacobian; a Jacobian without it is factored whole.

use crate::linalg;
use nalgebra::{Complex, ComplexField};

/// The coordinates of one joint: its positions `q0..q0 + nq` and velocities `v0..v0 + nv`
/// (indices into `q` and `v`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Block {
    /// First position coordinate.
    pub q0: usize,
    /// Number of position coordinates.
    pub nq: usize,
    /// First velocity coordinate (counted from the start of `v`).
    pub v0: usize,
    /// Number of velocity coordinates.
    pub nv: usize,
}

/// The second-order structure of a system `(q, v, e)`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct SecondOrder {
    /// Number of positions.
    pub nq: usize,
    /// Number of velocities.
    pub nv: usize,
    /// The joints, in any order, covering every position once.
    pub blocks: Vec<Block>,
}

impl SecondOrder {
    /// Whether the row-major `n × n` Jacobian `jac` has the structure: each joint's position
    /// rates depend on its own coordinates only, and no rate depends on the integrals.
    pub fn holds(&self, jac: &[f64], n: usize) -> bool {
        let nqv = self.nq + self.nv;
        if n < nqv || jac.len() != n * n {
            return false;
        }
        if (0..n).any(|r| jac[r * n + nqv..(r + 1) * n].iter().any(|&x| x != 0.0)) {
            return false;
        }
        self.blocks.iter().all(|b| {
            (b.q0..b.q0 + b.nq).all(|r| {
                let row = &jac[r * n..r * n + nqv];
                row.iter().enumerate().all(|(c, &x)| {
                    x == 0.0 || (b.q0..b.q0 + b.nq).contains(&c) || (self.nq + b.v0..self.nq + b.v0 + b.nv).contains(&c)
                })
            })
        })
    }
}

/// What both shifts share: the rows of the Jacobian a solve reads (copied at factorisation,
/// so that a solve does not depend on the Jacobian held).
#[derive(Debug, Clone)]
pub struct ReducedRows {
    /// `Aq`, `nv × nq`.
    aq: Vec<f64>,
    /// `(Eq Ev)`, `ne × (nq + nv)`.
    e: Vec<f64>,
    /// The integrals' count.
    ne: usize,
}

impl ReducedRows {
    /// Room for a system of `n` states with structure `s`.
    pub fn new(s: &SecondOrder, n: usize) -> ReducedRows {
        let ne = n.saturating_sub(s.nq + s.nv);
        ReducedRows {
            aq: vec![0.0; s.nv * s.nq],
            e: vec![0.0; ne * (s.nq + s.nv)],
            ne,
        }
    }

    /// Copies `Aq`, `Eq` and `Ev` from the row-major `n × n` Jacobian.
    pub fn load(&mut self, s: &SecondOrder, jac: &[f64], n: usize) {
        let nqv = s.nq + s.nv;
        for i in 0..s.nv {
            let r = (s.nq + i) * n;
            self.aq[i * s.nq..(i + 1) * s.nq].copy_from_slice(&jac[r..r + s.nq]);
        }
        for k in 0..self.ne {
            let r = (nqv + k) * n;
            self.e[k * nqv..(k + 1) * nqv].copy_from_slice(&jac[r..r + nqv]);
        }
    }
}

/// The factors of `I − cJ` reduced to the velocities, for a real or complex shift `c`.
#[derive(Debug, Clone)]
pub struct ReducedLu<T> {
    /// The shift the factors are for, and its inverse.
    c: T,
    inv_c: T,
    /// Per block (in order), `Q⁻¹` (`nq × nq`), then `cP = c Q⁻¹ T` (`nq × nv`).
    blocks: Vec<T>,
    /// Where each block's numbers start in `blocks`.
    offsets: Vec<usize>,
    /// `S / c` (`nv × nv`, row-major), and its LU factors in `linalg`'s layout for `T`
    /// ([`Field`]) with their permutation.
    s: Vec<T>,
    lu: Vec<f64>,
    perm: Vec<usize>,
    /// Scratch: a block's positions and unit vectors, the largest block's `Q` and its LU
    /// factors and permutation, and the solves' work.
    work_q: Vec<T>,
    work_m: Vec<T>,
    lu_q: Vec<f64>,
    perm_q: Vec<usize>,
    work: Vec<f64>,
}

/// The two fields the iteration matrices are factored in, each by `linalg`'s LU for it (the
/// complex one stores the real parts, then the imaginary parts).
pub trait Field: ComplexField<RealField = f64> + Copy {
    /// Numbers of `f64` per entry of the factors.
    const PARTS: usize;
    /// Factors the row-major `n × n` matrix `a` into `lu`; false when it is singular.
    fn factor(a: &[Self], n: usize, lu: &mut [f64], perm: &mut [usize]) -> bool;
    /// Solves with the factors of [`Field::factor`], in place (`work`: `2 · PARTS · n`).
    fn solve(lu: &[f64], n: usize, perm: &[usize], x: &mut [Self], work: &mut [f64]);
}

impl Field for f64 {
    const PARTS: usize = 1;
    fn factor(a: &[f64], n: usize, lu: &mut [f64], perm: &mut [usize]) -> bool {
        lu[..n * n].copy_from_slice(&a[..n * n]);
        linalg::lu_in_place(lu, n, perm)
    }
    fn solve(lu: &[f64], n: usize, perm: &[usize], x: &mut [f64], work: &mut [f64]) {
        linalg::lu_solve(lu, n, perm, x, work);
    }
}

impl Field for Complex<f64> {
    const PARTS: usize = 2;
    fn factor(a: &[Complex<f64>], n: usize, lu: &mut [f64], perm: &mut [usize]) -> bool {
        let (re, im) = lu[..2 * n * n].split_at_mut(n * n);
        for ((r, i), z) in re.iter_mut().zip(im.iter_mut()).zip(&a[..n * n]) {
            (*r, *i) = (z.re, z.im);
        }
        linalg::lu_in_place_complex(lu, n, perm)
    }
    fn solve(lu: &[f64], n: usize, perm: &[usize], x: &mut [Complex<f64>], work: &mut [f64]) {
        let (re, rest) = work[..4 * n].split_at_mut(n);
        let (im, scratch) = rest.split_at_mut(n);
        for ((r, i), z) in re.iter_mut().zip(im.iter_mut()).zip(&x[..n]) {
            (*r, *i) = (z.re, z.im);
        }
        linalg::lu_solve_complex(lu, n, perm, re, im, scratch);
        for ((r, i), z) in re.iter().zip(im.iter()).zip(&mut x[..n]) {
            *z = Complex::new(*r, *i);
        }
    }
}

/// A joint with one position and one velocity (revolute, prismatic): its `Q` and `P` are
/// numbers, and the reduction takes the short way.
fn scalar(b: &Block) -> bool {
    b.nq == 1 && b.nv == 1
}

impl<T: Field> ReducedLu<T> {
    /// Room for structure `s`.
    pub fn new(s: &SecondOrder) -> ReducedLu<T> {
        let mut offsets = Vec::with_capacity(s.blocks.len());
        let mut per_block = 0;
        for b in &s.blocks {
            offsets.push(per_block);
            per_block += b.nq * (b.nq + b.nv);
        }
        let largest = s.blocks.iter().map(|b| b.nq).max().unwrap_or(0);
        ReducedLu {
            c: T::zero(),
            inv_c: T::zero(),
            blocks: vec![T::zero(); per_block],
            offsets,
            s: vec![T::zero(); s.nv * s.nv],
            lu: vec![0.0; T::PARTS * s.nv * s.nv],
            perm: vec![0; s.nv],
            work_q: vec![T::zero(); largest],
            work_m: vec![T::zero(); largest * largest],
            lu_q: vec![0.0; T::PARTS * largest * largest],
            perm_q: vec![0; largest],
            work: vec![0.0; 2 * T::PARTS * s.nv.max(largest)],
        }
    }

    /// Factors `I − cJ` for the row-major `n × n` Jacobian `jac`, which must have the
    /// structure ([`SecondOrder::holds`]), and `c ≠ 0`. False when `I − cJ` is singular or
    /// a factor is not finite.
    pub fn factor(&mut self, s: &SecondOrder, jac: &[f64], n: usize, c: T) -> bool {
        let nq = s.nq;
        self.c = c;
        for (b, &off) in s.blocks.iter().zip(&self.offsets) {
            let (qinv, cp) = self.blocks[off..off + b.nq * (b.nq + b.nv)].split_at_mut(b.nq * b.nq);
            if scalar(b) {
                let q = T::one() - c.scale(jac[b.q0 * n + b.q0]);
                if q.norm1() == 0.0 {
                    return false;
                }
                qinv[0] = T::one() / q;
                cp[0] = c * qinv[0].scale(jac[b.q0 * n + nq + b.v0]);
                continue;
            }
            // Q = I − c Jqq, factored, and Q⁻¹ column by column
            let m = &mut self.work_m[..b.nq * b.nq];
            for i in 0..b.nq {
                for k in 0..b.nq {
                    let mut x = -c.scale(jac[(b.q0 + i) * n + b.q0 + k]);
                    if i == k {
                        x += T::one();
                    }
                    m[i * b.nq + k] = x;
                }
            }
            if !T::factor(m, b.nq, &mut self.lu_q, &mut self.perm_q) {
                return false;
            }
            let e = &mut self.work_q[..b.nq];
            for k in 0..b.nq {
                e.iter_mut()
                    .enumerate()
                    .for_each(|(i, x)| *x = if i == k { T::one() } else { T::zero() });
                T::solve(&self.lu_q, b.nq, &self.perm_q, e, &mut self.work);
                for (i, x) in e.iter().enumerate() {
                    qinv[i * b.nq + k] = *x;
                }
            }
            // cP = c Q⁻¹ T
            for i in 0..b.nq {
                for k in 0..b.nv {
                    let mut acc = T::zero();
                    for l in 0..b.nq {
                        acc += qinv[i * b.nq + l].scale(jac[(b.q0 + l) * n + nq + b.v0 + k]);
                    }
                    cp[i * b.nv + k] = c * acc;
                }
            }
        }
        // S / c = I / c − Av − Aq (cP) (divided by c: its entries scale as those of I − cJ, so
        // that a huge step does not overflow where the whole matrix would not)
        let nv = s.nv;
        let inv_c = T::one() / c;
        self.inv_c = inv_c;
        for (i, srow) in self.s.chunks_exact_mut(nv).enumerate() {
            let row = &jac[(nq + i) * n..(nq + i + 1) * n];
            for (x, &a) in srow.iter_mut().zip(&row[nq..nq + nv]) {
                *x = T::from_real(-a);
            }
            srow[i] += inv_c;
            for (b, &off) in s.blocks.iter().zip(&self.offsets) {
                let cp = &self.blocks[off + b.nq * b.nq..off + b.nq * (b.nq + b.nv)];
                if scalar(b) {
                    srow[b.v0] -= cp[0].scale(row[b.q0]);
                    continue;
                }
                for k in 0..b.nv {
                    let mut acc = T::zero();
                    for l in 0..b.nq {
                        acc += cp[l * b.nv + k].scale(row[b.q0 + l]);
                    }
                    srow[b.v0 + k] -= acc;
                }
            }
        }
        T::factor(&self.s, nv, &mut self.lu, &mut self.perm)
    }

    /// Solves `(I − cJ) x = x` in place with the factors and the rows `r` of the same
    /// Jacobian.
    pub fn solve(&mut self, s: &SecondOrder, r: &ReducedRows, x: &mut [T]) {
        let (nq, nv, c) = (s.nq, s.nv, self.c);
        let (xq, rest) = x.split_at_mut(nq);
        let (xv, xe) = rest.split_at_mut(nv);
        // Q⁻¹ bq
        for (b, &off) in s.blocks.iter().zip(&self.offsets) {
            if scalar(b) {
                xq[b.q0] *= self.blocks[off];
                continue;
            }
            let qinv = &self.blocks[off..off + b.nq * b.nq];
            let w = &mut self.work_q[..b.nq];
            for (i, wi) in w.iter_mut().enumerate() {
                let mut acc = T::zero();
                for l in 0..b.nq {
                    acc += qinv[i * b.nq + l] * xq[b.q0 + l];
                }
                *wi = acc;
            }
            xq[b.q0..b.q0 + b.nq].copy_from_slice(w);
        }
        // (S / c) xv = bv / c + Aq Q⁻¹ bq
        for (v, row) in xv.iter_mut().zip(r.aq.chunks_exact(nq.max(1))) {
            let mut acc = T::zero();
            for (a, q) in row.iter().zip(xq.iter()) {
                acc += q.scale(*a);
            }
            *v = *v * self.inv_c + acc;
        }
        T::solve(&self.lu, nv, &self.perm, xv, &mut self.work);
        // xq = Q⁻¹ bq + cP xv
        for (b, &off) in s.blocks.iter().zip(&self.offsets) {
            let cp = &self.blocks[off + b.nq * b.nq..off + b.nq * (b.nq + b.nv)];
            if scalar(b) {
                xq[b.q0] += cp[0] * xv[b.v0];
                continue;
            }
            for i in 0..b.nq {
                let mut acc = T::zero();
                for k in 0..b.nv {
                    acc += cp[i * b.nv + k] * xv[b.v0 + k];
                }
                xq[b.q0 + i] += acc;
            }
        }
        // xe = be + c (Eq xq + Ev xv)
        let nqv = nq + nv;
        for (k, e) in xe.iter_mut().enumerate().take(r.ne) {
            let row = &r.e[k * nqv..(k + 1) * nqv];
            let mut acc = T::zero();
            for (a, y) in row[..nq].iter().zip(xq.iter()).chain(row[nq..].iter().zip(xv.iter())) {
                acc += y.scale(*a);
            }
            *e += c * acc;
        }
    }
}

/// What an implicit method holds to solve with the reduced matrices: the structure, the
/// Jacobian rows a solve reads, the factors for the real shift and for the complex one, and
/// whether the last factorisation used them.
#[derive(Debug, Clone)]
pub struct Reduction {
    s: SecondOrder,
    rows: ReducedRows,
    real: ReducedLu<f64>,
    complex: ReducedLu<Complex<f64>>,
    work: Vec<Complex<f64>>,
    /// The last factorisation was reduced (the Jacobian had the structure).
    pub active: bool,
}

impl Reduction {
    /// Room for structure `s` in a system of `n` states.
    pub fn new(s: &SecondOrder, n: usize) -> Reduction {
        Reduction {
            s: s.clone(),
            rows: ReducedRows::new(s, n),
            real: ReducedLu::new(s),
            complex: ReducedLu::new(s),
            work: vec![Complex::new(0.0, 0.0); n],
            active: false,
        }
    }

    /// Factors `I − c_r J` and `I − c_c J` reduced when the row-major `n × n` Jacobian has
    /// the structure and the factors are regular and finite: then true, and
    /// [`Reduction::active`]. False otherwise: the caller factors the whole matrices (and
    /// decides there whether they are singular).
    pub fn factor(&mut self, jac: &[f64], n: usize, c_real: f64, c_complex: Complex<f64>) -> bool {
        self.active = self.s.holds(jac, n) && {
            self.rows.load(&self.s, jac, n);
            self.real.factor(&self.s, jac, n, c_real) && self.complex.factor(&self.s, jac, n, c_complex)
        };
        self.active
    }

    /// Solves `(I − c_r J) x = x` in place.
    pub fn solve_real(&mut self, x: &mut [f64]) {
        self.real.solve(&self.s, &self.rows, x);
    }

    /// Solves `(I − c_c J) (re + i im) = re + i im` in place.
    pub fn solve_complex(&mut self, re: &mut [f64], im: &mut [f64]) {
        for ((w, r), i) in self.work.iter_mut().zip(re.iter()).zip(im.iter()) {
            *w = Complex::new(*r, *i);
        }
        self.complex.solve(&self.s, &self.rows, &mut self.work);
        for ((w, r), i) in self.work.iter().zip(re.iter_mut()).zip(im.iter_mut()) {
            *r = w.re;
            *i = w.im;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A Jacobian with the structure: two revolute joints and one 2-position block with one
    /// velocity (as a quaternion-like block), one integral.
    fn system() -> (SecondOrder, Vec<f64>, usize) {
        let s = SecondOrder {
            nq: 4,
            nv: 3,
            blocks: vec![
                Block {
                    q0: 0,
                    nq: 1,
                    v0: 0,
                    nv: 1,
                },
                Block {
                    q0: 1,
                    nq: 1,
                    v0: 1,
                    nv: 1,
                },
                Block {
                    q0: 2,
                    nq: 2,
                    v0: 2,
                    nv: 1,
                },
            ],
        };
        let n = 8;
        let mut j = vec![0.0; n * n];
        let mut x = 0.37_f64;
        let mut next = || {
            x = (x * 7.3 + 0.11).fract();
            x - 0.5
        };
        j[4] = 1.0; // q0' = v0
        j[n + 5] = 1.0; // q1' = v1
        j[2 * n + 2] = 0.0;
        j[2 * n + 3] = 0.3;
        j[2 * n + 6] = 0.8;
        j[3 * n + 2] = -0.3;
        j[3 * n + 6] = 0.5;
        for r in 4..8 {
            for c in 0..7 {
                j[r * n + c] = 40.0 * next();
            }
        }
        (s, j, n)
    }

    /// Reference: `I − cJ` of the whole system factored and solved as radau5 does without
    /// the reduction (`linalg`'s LU).
    fn reference<T: Field>(j: &[f64], n: usize, c: T, b: &[T]) -> Vec<T> {
        let mut m = vec![T::zero(); n * n];
        for i in 0..n {
            for k in 0..n {
                m[i * n + k] = -c * T::from_real(j[i * n + k]) + if i == k { T::one() } else { T::zero() };
            }
        }
        let (mut lu, mut perm, mut work) = (vec![0.0; T::PARTS * n * n], vec![0; n], vec![0.0; 2 * T::PARTS * n]);
        assert!(T::factor(&m, n, &mut lu, &mut perm));
        let mut x = b.to_vec();
        T::solve(&lu, n, &perm, &mut x, &mut work);
        x
    }

    #[test]
    fn the_structure_is_recognised_and_a_coupling_breaks_it() {
        let (s, mut j, n) = system();
        assert!(s.holds(&j, n));
        j[2 * n + 5] = 1e-300; // a position rate that reads another joint's velocity
        assert!(!s.holds(&j, n));
        let (s, mut j, n) = system();
        j[5 * n + 7] = 1.0; // an acceleration that reads the integral
        assert!(!s.holds(&j, n));
    }

    #[test]
    fn the_reduced_solve_is_the_whole_systems_real_and_complex() {
        let (s, j, n) = system();
        let mut rows = ReducedRows::new(&s, n);
        rows.load(&s, &j, n);
        let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).sin()).collect();
        let mut lu = ReducedLu::<f64>::new(&s);
        assert!(lu.factor(&s, &j, n, 0.021));
        let mut x = b.clone();
        lu.solve(&s, &rows, &mut x);
        for (a, e) in x.iter().zip(reference(&j, n, 0.021, &b)) {
            assert!((a - e).abs() <= 1e-13 * e.abs().max(1.0), "{a} against {e}");
        }
        let c = Complex::new(0.013, -0.009);
        let bc: Vec<Complex<f64>> = b
            .iter()
            .enumerate()
            .map(|(i, &v)| Complex::new(v, 0.3 * i as f64))
            .collect();
        let mut lu = ReducedLu::<Complex<f64>>::new(&s);
        assert!(lu.factor(&s, &j, n, c));
        let mut x = bc.clone();
        lu.solve(&s, &rows, &mut x);
        for (a, e) in x.iter().zip(reference(&j, n, c, &bc)) {
            assert!((a - e).norm() <= 1e-13 * e.norm().max(1.0), "{a} against {e}");
        }
    }
}
