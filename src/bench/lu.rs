//! `bench lu`: the LU factorisations of the implicit methods' iteration matrices, dense and
//! sparse, on matrices shaped like a multibody system's Jacobian ([`multibody_jacobian`]):
//! (a) the own in-place dense LU of [`crate::linalg`], (b) faer's dense LU with partial
//! pivoting in place with caller-provided scratch, (c) faer's sparse LU (symbolic analysis
//! once, timed apart, then numeric factorisations). Forms: SDIRK4's `I − cJ` (n × n) and
//! RADAU5's `I − h A⊗J` (3n × 3n). Factorisation (forming the matrix included) and solve
//! times are medians of batches.

use super::scaling::time_per_call;
use super::{f, Csv};
use crate::integrator::linear::{JacRef, Lu, SparseJacobian, SupernodalThreshold};
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::lu::partial_pivoting::{factor as faer_factor, solve as faer_solve};
use faer::{Mat, MatMut, Par};
use std::path::Path;
use std::time::Instant;

/// States of one free body: position (3), quaternion (4), velocity (3), angular velocity (3).
const BODY: usize = 13;

/// A Jacobian with the structure of `n / 13` free bodies on a cubic lattice with a contact
/// between lattice neighbours (and the `n mod 13` states left as a small dense joint block
/// coupled to the first body): `ṙ = v` (identity), `q̇ = ½ Q(q) ω` (4 × 7), the accelerations
/// depending on the body's 13 states and on each contact partner's 13 (dense 6 × 13 blocks).
/// Values are pseudo-random: ±1e6 for accelerations against positions (stiff contacts), ±1e2
/// against velocities, ±1 elsewhere. Returned in compressed sparse columns.
pub fn multibody_jacobian(n: usize) -> SparseJacobian {
    let nb = n / BODY;
    let extra = n - nb * BODY;
    let side = (nb as f64).cbrt().ceil().max(1.0) as usize;
    let mut seed: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut rnd = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        2.0 * ((seed >> 11) as f64 / (1u64 << 53) as f64) - 1.0
    };
    // columns of each row
    let mut rows: Vec<Vec<usize>> = vec![Vec::new(); n];
    let body = |b: usize| b * BODY..(b + 1) * BODY;
    for b in 0..nb {
        let o = b * BODY;
        for k in 0..3 {
            rows[o + k].push(o + 7 + k);
        }
        for k in 3..7 {
            rows[o + k].extend((o + 3..o + 7).chain(o + 10..o + 13));
        }
        let (i, j, l) = (b % side, (b / side) % side, b / (side * side));
        let mut partners = vec![b];
        for (di, dj, dl) in [
            (1i64, 0i64, 0i64),
            (-1, 0, 0),
            (0, 1, 0),
            (0, -1, 0),
            (0, 0, 1),
            (0, 0, -1),
        ] {
            let (i2, j2, l2) = (i as i64 + di, j as i64 + dj, l as i64 + dl);
            let s = side as i64;
            if (0..s).contains(&i2) && (0..s).contains(&j2) && (0..s).contains(&l2) {
                let c = (i2 + s * (j2 + s * l2)) as usize;
                if c < nb {
                    partners.push(c);
                }
            }
        }
        if b == 0 && extra > 0 {
            for k in 7..13 {
                rows[o + k].extend(nb * BODY..n);
            }
        }
        for k in 7..13 {
            for &c in &partners {
                rows[o + k].extend(body(c));
            }
        }
    }
    for row in rows.iter_mut().skip(nb * BODY) {
        row.extend(nb * BODY..n);
        if nb > 0 {
            row.extend(body(0));
        }
    }
    // to columns, with the diagonal and values
    let mut cols: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
    for (i, r) in rows.iter_mut().enumerate() {
        r.push(i);
        r.sort_unstable();
        r.dedup();
        // accelerations: the bodies' last six rows and the joint block
        let accel = !(i < nb * BODY && i % BODY < 7);
        for &j in r.iter() {
            let of_position = !(j < nb * BODY && j % BODY >= 7);
            let scale = match (accel, of_position) {
                (true, true) => 1e6,
                (true, false) => 1e2,
                _ => 1.0,
            };
            cols[j].push((i, scale * rnd()));
        }
    }
    let (mut col_ptr, mut row_idx, mut val) = (vec![0], Vec::new(), Vec::new());
    for c in cols {
        for (i, v) in c {
            row_idx.push(i);
            val.push(v);
        }
        col_ptr.push(row_idx.len());
    }
    SparseJacobian::from_csc(n, col_ptr, row_idx, val)
}

/// The row-major dense copy of a sparse Jacobian.
fn dense_of(jac: &SparseJacobian, n: usize) -> Vec<f64> {
    let mut d = vec![0.0; n * n];
    for j in 0..n {
        for k in jac.col_ptr[j]..jac.col_ptr[j + 1] {
            d[jac.row_idx[k] * n + j] = jac.val[k];
        }
    }
    d
}

/// RADAU5's Butcher matrix (rounded; the timing does not depend on the digits).
const A: [[f64; 3]; 3] = [
    [0.196_815_477_223_660, -0.065_535_425_850_198, 0.023_770_974_348_220],
    [0.394_424_314_739_087, 0.292_073_411_665_228, -0.041_548_752_125_998],
    [0.376_403_062_700_467, 0.512_485_826_188_421, 0.111_111_111_111_111],
];
/// Largest n whose 3n × 3n RADAU5 matrix is factored (sparse: about a minute at n = 5,000).
const KRON_MAX: usize = 5000;

/// Step size times γ of the matrices (stiff: c·1e6 ≫ 1).
const C: f64 = 1e-4;

/// Median seconds of one call of `body` over `repeats` batches of about 20 ms each.
fn time_one(repeats: usize, mut body: impl FnMut()) -> f64 {
    let t = Instant::now();
    body();
    let once = t.elapsed().as_secs_f64().max(1e-8);
    let iters = ((0.02 / once) as usize).clamp(1, 1_000_000);
    time_per_call(repeats, iters, &mut body)
}

/// Largest |A x − b| / |b| of a solution, `a` row-major.
fn residual(a: &[f64], m: usize, x: &[f64], b: &[f64]) -> f64 {
    let bmax = b.iter().fold(0.0_f64, |s, v| s.max(v.abs()));
    let mut worst = 0.0_f64;
    for i in 0..m {
        let r: f64 = (0..m).map(|j| a[i * m + j] * x[j]).sum::<f64>() - b[i];
        worst = worst.max(r.abs());
    }
    worst / bmax
}

/// Factors the iteration matrix of a form (`I − h A⊗J` when `kron`, else `I − cJ`) with
/// [`C`] and [`A`]; false if singular.
fn factor(lu: &mut Lu, jac: JacRef, kron: bool) -> bool {
    if kron {
        lu.factor_kron(jac, C, &A)
    } else {
        lu.factor_shifted(jac, C)
    }
}

/// The dense iteration matrix of a form, row-major.
fn dense_matrix(jd: &[f64], n: usize, kron: bool) -> Vec<f64> {
    let m = if kron { 3 * n } else { n };
    let mut a = vec![0.0; m * m];
    if kron {
        for (bi, row) in A.iter().enumerate() {
            for (bj, aij) in row.iter().enumerate() {
                for i in 0..n {
                    for j in 0..n {
                        a[(bi * n + i) * m + bj * n + j] = -C * aij * jd[i * n + j];
                    }
                }
            }
        }
    } else {
        for (x, j) in a.iter_mut().zip(jd) {
            *x = -C * j;
        }
    }
    for i in 0..m {
        a[i * m + i] += 1.0;
    }
    a
}

/// Runs the benchmark for the sizes `ns` (dense up to `dense_max`) and writes the CSV.
pub fn run(ns: &[usize], dense_max: usize, repeats: usize, csv_path: &Path) -> Result<(), String> {
    let mut csv = Csv::new(&[
        "form",
        "n",
        "size",
        "nnz",
        "solver",
        "analyse_seconds",
        "factor_seconds",
        "solve_seconds",
        "residual",
    ]);
    println!(
        "{:>7} {:>6} {:>6} {:>9} {:>12} {:>12} {:>12} {:>12} {:>9}",
        "form", "n", "size", "nnz", "solver", "analyse [µs]", "factor [µs]", "solve [µs]", "residual"
    );
    let mut emit =
        |form: &str, n: usize, m: usize, nnz: usize, solver: &str, an: Option<f64>, tf: f64, ts: f64, res: f64| {
            let us = |x: f64| format!("{:.2}", x * 1e6);
            println!(
                "{:>7} {:>6} {:>6} {:>9} {:>12} {:>12} {:>12} {:>12} {:>9.1e}",
                form,
                n,
                m,
                nnz,
                solver,
                an.map(us).unwrap_or_else(|| "-".into()),
                us(tf),
                us(ts),
                res
            );
            csv.push(vec![
                form.into(),
                n.to_string(),
                m.to_string(),
                nnz.to_string(),
                solver.into(),
                an.map(f).unwrap_or_default(),
                f(tf),
                f(ts),
                f(res),
            ]);
        };
    for &n in ns {
        let jac = multibody_jacobian(n);
        let reps = if n >= 5000 { repeats.min(3) } else { repeats };
        for kron in [false, true] {
            if kron && n > KRON_MAX {
                continue;
            }
            let form = if kron { "kron3" } else { "shifted" };
            let m = if kron { 3 * n } else { n };
            let nnz = if kron { 9 * jac.nnz() } else { jac.nnz() };
            let b: Vec<f64> = (0..m).map(|i| ((i * 7 + 3) % 11) as f64 - 5.0).collect();
            let dense_ok = m <= dense_max;
            let a = if dense_ok || m <= 3000 {
                Some(dense_matrix(&dense_of(&jac, n), n, kron))
            } else {
                None
            };
            let check = |x: &[f64]| a.as_ref().map(|a| residual(a, m, x, &b)).unwrap_or(f64::NAN);
            if dense_ok {
                let jd = dense_of(&jac, n);
                // (a) own dense LU (the integrators' code path)
                let mut lu = Lu::new(m, false);
                let tf = time_one(reps, || {
                    let ok = factor(&mut lu, JacRef::Dense(&jd), kron);
                    assert!(ok);
                });
                let mut x = b.clone();
                let ts = time_one(reps, || {
                    x.copy_from_slice(&b);
                    lu.solve(&mut x);
                });
                emit(form, n, m, nnz, "own_dense", None, tf, ts, check(&x));
                // (b) faer's dense LU in place with caller-provided scratch
                let a_row = a.as_ref().expect("dense matrix");
                let mut mat = Mat::<f64>::zeros(m, m);
                let (mut perm, mut perm_inv) = (vec![0usize; m], vec![0usize; m]);
                let req = StackReq::any_of(&[
                    faer_factor::lu_in_place_scratch::<usize, f64>(m, m, Par::Seq, Default::default()),
                    faer_solve::solve_in_place_scratch::<usize, f64>(m, 1, Par::Seq),
                ]);
                let mut mem = MemBuffer::new(req);
                let mut xf = b.clone();
                // forming the matrix: a column-major copy (the integrators would write I − cJ)
                let tf = time_one(reps, || {
                    for j in 0..m {
                        for i in 0..m {
                            mat[(i, j)] = a_row[i * m + j];
                        }
                    }
                    faer_factor::lu_in_place(
                        mat.as_mut(),
                        &mut perm,
                        &mut perm_inv,
                        Par::Seq,
                        MemStack::new(&mut mem),
                        Default::default(),
                    );
                });
                let perm_ref = faer::perm::PermRef::new_checked(&perm, &perm_inv, m);
                let ts = time_one(reps, || {
                    xf.copy_from_slice(&b);
                    faer_solve::solve_in_place(
                        mat.as_ref(),
                        mat.as_ref(),
                        perm_ref,
                        MatMut::from_column_major_slice_mut(&mut xf, m, 1),
                        Par::Seq,
                        MemStack::new(&mut mem),
                    );
                });
                emit(form, n, m, nnz, "faer_dense", None, tf, ts, check(&xf));
            }
            // (c) faer's sparse LU: analysis once, then numeric factorisations; supernodal (the
            // integrators' choice), faer's own choice of kernel, simplicial
            for (name, threshold) in [
                ("faer_sparse", SupernodalThreshold::FORCE_SUPERNODAL),
                ("sparse_auto", SupernodalThreshold::AUTO),
                ("sparse_simplicial", SupernodalThreshold::FORCE_SIMPLICIAL),
            ] {
                if threshold != SupernodalThreshold::FORCE_SUPERNODAL && m > 3000 {
                    continue; // the alternatives, measured up to 3,000 rows, only lose more above
                }
                let mut lu = Lu::new(m, true);
                if let Lu::Sparse(s) = &mut lu {
                    s.threshold = threshold;
                }
                let t0 = Instant::now();
                let ok = factor(&mut lu, JacRef::Sparse(&jac), kron);
                assert!(ok, "sparse LU failed at n = {n}");
                let first = t0.elapsed().as_secs_f64();
                let mut x = b.clone();
                let tf = time_one(reps, || {
                    let ok = factor(&mut lu, JacRef::Sparse(&jac), kron);
                    assert!(ok);
                });
                let ts = time_one(reps, || {
                    x.copy_from_slice(&b);
                    lu.solve(&mut x);
                });
                // the analysis: the first call minus a numeric factorisation
                emit(form, n, m, nnz, name, Some((first - tf).max(0.0)), tf, ts, check(&x));
            }
        }
    }
    csv.write(csv_path)
}

/// N spheres in a box ([`super::scenes::sphere_box`]) with sdirk and radau5, on the dense and
/// on the sparse path ([`crate::integrator::linear::set_policy`]): run time per simulated
/// second, steps, RHS and Jacobian evaluations, sparse factorisations. A dense run whose
/// factorisation would take longer than `dense_budget` seconds (estimated at 1 GFlop/s) is
/// skipped.
pub fn run_scenes(ns: &[usize], time: f64, repeats: usize, dense_budget: f64, csv_path: &Path) -> Result<(), String> {
    use super::{scenes, RunSpec};
    use crate::integrator::linear::{set_policy, Policy};
    use crate::scene::Method;
    let mut csv = Csv::new(&[
        "n_spheres",
        "states",
        "method",
        "path",
        "seconds_per_simulated_second",
        "steps",
        "rhs_evals",
        "jac_evals",
        "sparse_factorisations",
        "probes",
        "coloured",
        "colours",
        "nnz",
        "final_x0",
        "status",
    ]);
    println!(
        "{:>5} {:>6} {:>7} {:>7} {:>12} {:>7} {:>9} {:>6} {:>8} {:>6} {:>8} {:>7} {:>8} {:>14}",
        "N",
        "n",
        "method",
        "path",
        "s per sim s",
        "steps",
        "rhs",
        "jac",
        "sp.fact",
        "probes",
        "coloured",
        "colours",
        "nnz",
        "s0.r[1] at end"
    );
    for &nsph in ns {
        let states = 13 * nsph;
        for method in [Method::Sdirk, Method::Radau5] {
            for sparse in [false, true] {
                let m = if method == Method::Radau5 { 3 * states } else { states };
                let est = 2.0 / 3.0 * (m as f64).powi(3) / 1e9;
                let path = if sparse { "sparse" } else { "dense" };
                if !sparse && est > dense_budget {
                    println!(
                        "{:>5} {:>6} {:>7} {:>7} not run: one dense factorisation ≈ {est:.0} s",
                        nsph,
                        states,
                        method.name(),
                        path
                    );
                    csv.push(vec![
                        nsph.to_string(),
                        states.to_string(),
                        method.name().into(),
                        path.into(),
                        String::new(),
                        String::new(),
                        String::new(),
                        String::new(),
                        String::new(),
                        String::new(),
                        String::new(),
                        String::new(),
                        String::new(),
                        String::new(),
                        format!("skipped: one factorisation ≈ {est:.0} s"),
                    ]);
                    continue;
                }
                set_policy(if sparse { Policy::Sparse } else { Policy::Dense });
                let spec = RunSpec::new(
                    scenes::sphere_box(nsph, time),
                    &format!("sphere_box_{nsph}"),
                    time,
                    time / 10.0,
                )
                .method(method);
                let reps = if sparse { repeats } else { repeats.min(3) };
                // timed runs; the counters, the linear algebra's counters and the final state
                // from the last
                let mut walls = Vec::new();
                let mut last = None;
                for _ in 0..reps.max(1) {
                    let mut sim = super::setup(&spec)?;
                    let t0 = Instant::now();
                    let r = sim.run(time, time / 10.0, |_| Ok(()));
                    walls.push(t0.elapsed().as_secs_f64());
                    last = Some((sim, r.err().map(|e| format!("{e:?}"))));
                }
                let wall = super::median(&walls);
                let (mut sim, failure) = last.expect("one run");
                let c = sim.counters();
                let ls = sim
                    .data()
                    .and_then(|d| d.solver.method())
                    .and_then(|i| i.linear_stats())
                    .unwrap_or_default();
                let x0 = match sim.table().index_of("s0.r[1]") {
                    Some(i) => sim.get(i).unwrap_or(f64::NAN),
                    None => f64::NAN,
                };
                set_policy(Policy::Auto);
                let per_sim = wall / time;
                println!(
                    "{:>5} {:>6} {:>7} {:>7} {:>12.4e} {:>7} {:>9} {:>6} {:>8} {:>6} {:>8} {:>7} {:>8} {:>14.9e} {}",
                    nsph,
                    states,
                    method.name(),
                    path,
                    per_sim,
                    c.steps,
                    c.rhs_evals,
                    c.jac_evals,
                    ls.sparse_factorisations,
                    ls.probes,
                    ls.coloured,
                    ls.colours,
                    ls.nnz,
                    x0,
                    failure.as_deref().unwrap_or("")
                );
                csv.push(vec![
                    nsph.to_string(),
                    states.to_string(),
                    method.name().into(),
                    path.into(),
                    f(per_sim),
                    c.steps.to_string(),
                    c.rhs_evals.to_string(),
                    c.jac_evals.to_string(),
                    ls.sparse_factorisations.to_string(),
                    ls.probes.to_string(),
                    ls.coloured.to_string(),
                    ls.colours.to_string(),
                    ls.nnz.to_string(),
                    format!("{x0:.12e}"),
                    failure.unwrap_or_else(|| "ok".into()),
                ]);
            }
        }
    }
    csv.write(csv_path)
}
