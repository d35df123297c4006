//! The integrators' common unit tests: no allocation in a step, warm restarts that keep the
//! Jacobian, and saved states that continue bit for bit or are refused without a change.

use super::test_problems::*;
use super::warm::{WarmMemory, FAILURE_BURST_STEPS, FILTERED_START_STEPS, WARM_HEADER};
use super::*;

/// Solver settings for `method` with largest step 0.01.
fn settings(method: Method, rtol: f64, atol: f64) -> SolverSection {
    SolverSection {
        method,
        rtol,
        atol,
        max_step: 1e-2,
        ..SolverSection::default()
    }
}

/// After construction and reset, stepping allocates nothing (every method).
#[test]
fn stepping_does_not_allocate() {
    for method in Method::ALL {
        let mut m = create(&settings(method, 1e-8, 1e-10), 2);
        let mut sys = SpringDamper { omega: 10.0, g: 9.81 };
        m.reset(&mut sys, 0.0, &[0.0, -1.0], 0.0);
        m.step(&mut sys, 1.0).unwrap();
        let before = alloc_counter::count();
        let mut out = [0.0; 2];
        while m.t() < 0.5 {
            m.step(&mut sys, 0.5).unwrap();
            m.interpolate(0.5 * (m.t() + m.t_prev()), &mut out);
        }
        m.reset(&mut sys, 0.5, &[0.0, 1.0], m.next_step());
        m.step(&mut sys, 1.0).unwrap();
        let (t1, y1) = (m.t(), [m.y()[0], m.y()[1]]);
        m.restart(&mut sys, t1, &y1, m.next_step());
        m.step(&mut sys, 1.0).unwrap();
        assert_eq!(
            alloc_counter::count() - before,
            0,
            "{method:?} allocated while stepping"
        );
    }
}

/// Steps `m` to `t_end`.
fn run_to(m: &mut dyn Integrator, sys: &mut dyn OdeSystem, t_end: f64) {
    while m.t() < t_end {
        m.step(sys, t_end).unwrap();
    }
}

/// A warm restart keeps the implicit methods' Jacobian (a cold one must evaluate a new
/// one on a stiff problem), and it depends only on `(t, y, h)` and the warm state: another
/// integrator with other history, given that warm state, continues bit for bit.
#[test]
fn warm_restart_keeps_the_jacobian_and_is_reproduced_from_the_warm_state() {
    for method in [Method::Sdirk, Method::Radau5] {
        let s = settings(method, 1e-6, 1e-8);
        let mut sys = SpringDamper { omega: 1e4, g: 9.81 };
        let mut a = create(&s, 2);
        a.reset(&mut sys, 0.0, &[0.0, -1.0], 0.0);
        run_to(a.as_mut(), &mut sys, 0.01);
        let mut w = Vec::new();
        a.warm_state(&mut w);
        assert_eq!(w.len(), WARM_HEADER + 4, "{method:?}: memory and a 2×2 Jacobian");
        let (t, y, h) = (a.t(), a.y().to_vec(), a.next_step());
        let mut b = create(&s, 2);
        b.reset(&mut sys, 0.0, &[0.3, 2.0], 0.0);
        run_to(b.as_mut(), &mut sys, 0.2);
        b.set_warm_state(&w).unwrap();
        let mut cold = create(&s, 2);
        cold.reset(&mut sys, t, &y, h);
        let jac0 = a.stats().jac_evals;
        a.restart(&mut sys, t, &y, h);
        b.restart(&mut sys, t, &y, h);
        while a.t() < 0.05 {
            a.step(&mut sys, 0.05).unwrap();
            b.step(&mut sys, 0.05).unwrap();
            assert_eq!(a.t().to_bits(), b.t().to_bits(), "{method:?}");
            assert_eq!(a.y(), b.y(), "{method:?} at t = {}", a.t());
        }
        run_to(cold.as_mut(), &mut sys, 0.05);
        assert_eq!(a.stats().jac_evals, jac0, "{method:?}: the warm restart re-evaluated J");
        assert!(
            cold.stats().jac_evals >= 1,
            "{method:?}: a cold start needs a Jacobian here"
        );
        let exact = sys.exact(0.05, -1.0);
        assert!(
            test_problems::max_diff(a.y(), &exact) < 1e-6,
            "{method:?}: {:?} vs {exact:?}",
            a.y()
        );
    }
}

/// Explicit methods keep nothing; malformed memory is refused; a Jacobian above
/// [`WARM_JACOBIAN_MAX`] numbers is neither saved nor kept.
#[test]
fn warm_state_sizes_and_checks() {
    for method in [Method::Dopri5, Method::Rk4] {
        let mut m = create(&settings(method, 1e-6, 1e-8), 2);
        let mut w = vec![7.0];
        m.warm_state(&mut w);
        assert_eq!(w, [7.0], "{method:?}");
        assert!(m.set_warm_state(&[]).is_ok());
        assert!(m.set_warm_state(&[1.0]).is_err());
    }
    for method in [Method::Sdirk, Method::Radau5] {
        let mut m = create(&settings(method, 1e-6, 1e-8), 2);
        let mut w = Vec::new();
        m.warm_state(&mut w);
        assert_eq!(w.len(), WARM_HEADER, "{method:?}: no Jacobian before one is evaluated");
        assert!(m.set_warm_state(&[]).is_ok());
        // burst counters: since the last failure (at most FAILURE_BURST_STEPS + 1: none) and
        // filtered steps left (at most FILTERED_START_STEPS)
        let (none, full) = ((FAILURE_BURST_STEPS + 1) as f64, FILTERED_START_STEPS as f64);
        assert!(
            m.set_warm_state(&[0.0, 0.0, 1.0, 0.0, 1.0, 0.0, none, 0.0, 1.0])
                .is_err(),
            "{method:?}: short Jacobian"
        );
        assert!(m.set_warm_state(&[0.0; 3]).is_err(), "{method:?}");
        assert!(
            m.set_warm_state(&[0.0, 0.0, 1.0, 0.0, 0.0, 0.0, none, 0.0]).is_ok(),
            "{method:?}"
        );
        assert!(
            m.set_warm_state(&[0.0, 0.0, 1.0, 0.0, 0.0, 0.5, 2.0, full]).is_ok(),
            "{method:?}: a bound, a burst"
        );
        for bad in [-1.0, f64::NAN, f64::INFINITY] {
            assert!(
                m.set_warm_state(&[0.0, 0.0, 1.0, 0.0, 0.0, bad, none, 0.0]).is_err(),
                "{method:?}: step-size bound {bad}"
            );
        }
        for (since, left) in [
            (none + 1.0, 0.0),
            (0.5, 0.0),
            (none, full + 1.0),
            (none, -1.0),
            (f64::NAN, 0.0),
        ] {
            assert!(
                m.set_warm_state(&[0.0, 0.0, 1.0, 0.0, 0.0, 0.0, since, left]).is_err(),
                "{method:?}: burst counters {since} {left}"
            );
        }
    }
    // n = 201: n² > WARM_JACOBIAN_MAX
    struct Decay;
    impl OdeSystem for Decay {
        fn rhs(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) {
            for (d, v) in dy.iter_mut().zip(y) {
                *d = -1e4 * (v - 1.0);
            }
        }
    }
    let n = 201;
    assert!(n * n > WARM_JACOBIAN_MAX);
    let mut m = create(&settings(Method::Sdirk, 1e-6, 1e-8), n);
    m.reset(&mut Decay, 0.0, &vec![0.0; n], 0.0);
    run_to(m.as_mut(), &mut Decay, 0.01);
    assert!(m.stats().jac_evals >= 1);
    let mut w = Vec::new();
    m.warm_state(&mut w);
    assert_eq!(w.len(), WARM_HEADER, "a big Jacobian is not saved");
    let (t, y, h, j0) = (m.t(), m.y().to_vec(), m.next_step(), m.stats().jac_evals);
    m.restart(&mut Decay, t, &y, h);
    run_to(m.as_mut(), &mut Decay, 0.02);
    assert!(
        m.stats().jac_evals > j0,
        "a big Jacobian is recomputed after a warm restart"
    );
}

/// Deterministic pseudo-random numbers in [0, 1) (SplitMix64).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// How far one step may go: `Far` (a limit far beyond, the step is not cut), `Near(f)`
/// (`t + f·next_step`: cut or stretched when f < 1.01), `Here` (`t` itself: a
/// zero-length arrival).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Limit {
    Far,
    Near(f64),
    Here,
}

/// A fixed sequence of limits for `steps` steps: mostly far, some near, a few zero-length.
fn limits(seed: u64, steps: usize) -> Vec<Limit> {
    let mut rng = Rng(seed);
    (0..steps)
        .map(|_| {
            let (u, f) = (rng.next(), rng.next());
            if u < 0.7 {
                Limit::Far
            } else if u < 0.92 {
                Limit::Near(0.05 + 1.2 * f)
            } else {
                Limit::Here
            }
        })
        .collect()
}

/// The `t_max` of a step of `m` under `limit` (a function of the state only, so equal for
/// integrators in equal states).
fn t_max(m: &dyn Integrator, limit: Limit) -> f64 {
    match limit {
        Limit::Far => m.t() + 1e6,
        Limit::Near(f) => m.t() + f * m.next_step(),
        Limit::Here => m.t(),
    }
}

/// Bits of a slice (so that NaNs compare too).
fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// Everything observable of `a` and `b` is identical to the bit: `t`, `t_prev`, `y`,
/// `next_step`, counters, and the dense output at points inside the last step and at its ends.
fn assert_same(a: &dyn Integrator, b: &dyn Integrator, what: &str) {
    assert_eq!(a.t().to_bits(), b.t().to_bits(), "{what}: t {} vs {}", a.t(), b.t());
    assert_eq!(a.t_prev().to_bits(), b.t_prev().to_bits(), "{what}: t_prev");
    assert_eq!(bits(a.y()), bits(b.y()), "{what}: y {:?} vs {:?}", a.y(), b.y());
    assert_eq!(a.next_step().to_bits(), b.next_step().to_bits(), "{what}: next step");
    assert_eq!(a.stats(), b.stats(), "{what}: counters");
    let n = a.y().len();
    let (mut oa, mut ob) = (vec![0.0; n], vec![0.0; n]);
    let (t0, t1) = (a.t_prev(), a.t());
    for s in [0.0, 0.013, 0.25, 0.5, 0.618, 0.9, 0.999, 1.0] {
        let t = t0 + s * (t1 - t0);
        a.interpolate(t, &mut oa);
        b.interpolate(t, &mut ob);
        assert_eq!(bits(&oa), bits(&ob), "{what}: dense output at θ = {s}");
    }
}

/// One step of each under the same limit: the same result and the same state after it.
fn step_all(ms: &mut [Box<dyn Integrator + Send>], sys: &mut dyn OdeSystem, limit: Limit, what: &str) {
    let tm = t_max(ms[0].as_ref(), limit);
    let results: Vec<_> = ms.iter_mut().map(|m| m.step(sys, tm)).collect();
    for (m, r) in ms.iter().zip(&results).skip(1) {
        assert_eq!(r, &results[0], "{what}: step result");
        assert_same(ms[0].as_ref(), m.as_ref(), what);
    }
}

/// A problem for the save/load tests: system, start, solver settings, which methods.
struct Case {
    name: &'static str,
    sys: Box<dyn OdeSystem>,
    y0: Vec<f64>,
    s: SolverSection,
    implicit_only: bool,
    seed: u64,
}

/// The cases, one a line: name, system, start, rtol, atol, max_step, implicit methods only,
/// seed.
#[rustfmt::skip]
fn cases() -> Vec<Case> {
    let case = |name, sys: Box<dyn OdeSystem>, y0: &[f64], rtol, atol, max_step, implicit_only, seed| Case {
        name,
        sys,
        y0: y0.to_vec(),
        s: SolverSection { method: Method::Dopri5, rtol, atol, max_step, ..SolverSection::default() },
        implicit_only,
        seed,
    };
    vec![
        case("growth", Box::new(Growth), &Growth::exact(0.0), 1e-6, 1e-8, 0.05, false, 1),
        case("smooth", Box::new(Smooth), &Smooth::exact(0.0), 1e-9, 1e-10, 0.1, false, 2),
        case("soft spring", Box::new(SpringDamper { omega: 10.0, g: 9.81 }), &[0.0, -1.0], 1e-7, 1e-9, 1e-2, false, 3),
        // stiff: dopri5 sits at its stability limit (rejections); the implicit methods
        // keep one Jacobian
        case("prothero-robinson", Box::new(ProtheroRobinson { lambda: -1e5 }), &[0.0], 1e-6, 1e-6, 0.5, true, 4),
        case("stiff spring", Box::new(SpringDamper { omega: 1e4, g: 9.81 }), &[0.0, -1.0], 1e-8, 1e-10, 1e-2, true, 5),
        // stiff and nonlinear: stale Jacobians, refreshes, Newton failures, rejections
        case("van der pol", Box::new(VanDerPol { eps: 1e-3 }), &[2.0, -0.66], 1e-6, 1e-6, 0.1, true, 6),
        case("stiff cubic", Box::new(StiffCubic { lambda: 1e4 }), &[0.0], 1e-5, 1e-7, 0.5, true, 7),
        // loose: Newton converges slowly yet accepts, so the Jacobian goes stale
        case("cubic, loose", Box::new(StiffCubic { lambda: 1e2 }), &[0.0], 1e-3, 1e-5, 0.05, true, 8),
    ]
}

fn is_implicit(method: Method) -> bool {
    matches!(method, Method::Sdirk | Method::Radau5)
}

/// Numbers of an implicit method's dense output in its saved state (sdirk: 3 vectors;
/// radau5: the 3 stage increments of its collocation polynomial).
fn dense_len(_method: Method, n: usize) -> usize {
    3 * n
}

/// Where the Newton part of an implicit method's saved state begins (system size `n`).
fn newton_offset(method: Method, n: usize) -> usize {
    1 + StepCore::saved_len(n) + dense_len(method, n)
}

/// Length of a saved state of `method` for size `n` (implicit: with the Jacobian when
/// `with_jac`; auto: of the active method `inner`).
fn saved_len(method: Method, n: usize, with_jac: bool) -> usize {
    match method {
        Method::Dopri5 => 9 + 7 * n,
        Method::Rk4 => 8 + 4 * n,
        Method::Sdirk | Method::Radau5 => 18 + 3 * n + dense_len(method, n) + if with_jac { n * n } else { 0 },
        Method::Auto => unreachable!("auto: the length of its active method's state"),
    }
}

/// The method whose state a saved state of `method` holds, and where that state begins
/// (auto: after its tag and switching memory, the active method's).
fn layout(method: Method, w: &[f64]) -> (Method, usize) {
    if method == Method::Auto {
        let inner = if w[1] == 1.0 { Method::Radau5 } else { Method::Dopri5 };
        (inner, 1 + auto::MEMORY_LEN)
    } else {
        (method, 0)
    }
}

/// Steps of the first run before a save point (at most), and steps compared after it.
const BEFORE: usize = 300;
const AFTER: usize = 200;

/// Runs `m` from the case's start through `limits`.
fn run_steps(m: &mut dyn Integrator, c: &mut Case, limits: &[Limit]) {
    m.reset(c.sys.as_mut(), 0.0, &c.y0, 0.0);
    for &l in limits {
        let tm = t_max(m, l);
        let _ = m.step(c.sys.as_mut(), tm);
    }
}

/// A state saved after k steps and loaded into a fresh integrator (and into one with
/// another history) continues bit for bit like the uninterrupted run: dense output inside
/// the last step, then 200 more steps (results, t, y, next step, counters, dense output,
/// and in the end the whole saved state). The save points are pseudo-random, plus the
/// first ones after a cut step, after a zero-length arrival, with a stale Jacobian (the
/// next step refreshes it) and with a fresh one.
#[test]
fn a_loaded_state_continues_bit_for_bit() {
    // (stale J saved, fresh J saved, J refreshed after the load, LU refactored on load,
    // rejections after the load) seen per implicit method
    let mut seen = std::collections::BTreeMap::new();
    for mut c in cases() {
        for method in Method::ALL {
            if c.implicit_only && method == Method::Rk4 {
                continue;
            }
            let s = SolverSection { method, ..c.s };
            let n = c.y0.len();
            let lim = limits(c.seed * 16 + method as u64, BEFORE + AFTER);
            // scout: the state after every step
            let mut scout = create(&s, n);
            scout.reset(c.sys.as_mut(), 0.0, &c.y0, 0.0);
            let mut states = Vec::new();
            for &l in &lim[..BEFORE] {
                let mut w = Vec::new();
                scout.save_state(&mut w);
                states.push(w);
                let tm = t_max(scout.as_ref(), l);
                let _ = scout.step(c.sys.as_mut(), tm);
            }
            let mut rng = Rng(c.seed * 1000 + method as u64);
            let mut ks = vec![0, 1];
            ks.extend((0..4).map(|_| 2 + (rng.next() * (BEFORE - 2) as f64) as usize));
            let first = |p: &dyn Fn(usize) -> bool| (1..BEFORE).find(|&k| p(k));
            ks.extend(first(&|k| matches!(lim[k - 1], Limit::Near(f) if f < 1.0)));
            ks.extend(first(&|k| matches!(lim[k - 1], Limit::Here)));
            let implicit_at = |k: usize| {
                let (inner, base) = layout(method, &states[k]);
                is_implicit(inner).then_some(base + newton_offset(inner, n))
            };
            let stale = first(&|k| implicit_at(k).is_some_and(|o| states[k][o + 3] == 1.0));
            ks.extend(stale);
            ks.extend(first(&|k| implicit_at(k).is_some_and(|o| states[k][o + 5] == 1.0)));
            if method == Method::Auto {
                // the first states after each switch
                ks.extend((1..BEFORE).filter(|&k| states[k][1] != states[k - 1][1]));
            }
            ks.sort_unstable();
            ks.dedup();
            // save points: the first k limits, and with a stale Jacobian also a zero-length
            // arrival after them (which evaluates the Jacobian: a fresh one is saved)
            let mut prefixes: Vec<Vec<Limit>> = ks.iter().map(|&k| lim[..k].to_vec()).collect();
            prefixes.extend(stale.map(|k| [&lim[..k], &[Limit::Here][..]].concat()));
            for prefix in prefixes {
                let k = prefix.len();
                let what = format!("{method:?} on {} saved after {k} steps", c.name);
                let mut a = create(&s, n);
                run_steps(a.as_mut(), &mut c, &prefix);
                let mut w = Vec::new();
                a.save_state(&mut w);
                if prefix[..] == lim[..k] {
                    assert_eq!(bits(&w), bits(&states[k]), "{what}: the run is deterministic");
                }
                let (inner, base) = layout(method, &w);
                let with_jac = is_implicit(inner) && w[base + newton_offset(inner, n) + 4] == 1.0;
                assert_eq!(w.len(), base + saved_len(inner, n, with_jac), "{what}: length");
                // b: fresh; other: with another history (a Jacobian, LU factors,
                // stages and scratch of its own) before the load
                let mut b = create(&s, n);
                b.load_state(&w).unwrap_or_else(|e| panic!("{what}: {e}"));
                let mut other = create(&s, n);
                let y_other: Vec<f64> = c.y0.iter().map(|v| 0.5 * v + 0.25).collect();
                other.reset(c.sys.as_mut(), 0.3, &y_other, 0.0);
                for &l in &lim[BEFORE - 30..BEFORE] {
                    let tm = t_max(other.as_ref(), l);
                    let _ = other.step(c.sys.as_mut(), tm);
                }
                other.load_state(&w).unwrap_or_else(|e| panic!("{what}: {e}"));
                for m in [&b, &other] {
                    let mut w2 = Vec::new();
                    m.save_state(&mut w2);
                    assert_eq!(bits(&w2), bits(&w), "{what}: saved again after the load");
                    assert_same(a.as_ref(), m.as_ref(), &what);
                }
                let mut ms = [a, b, other];
                if is_implicit(method) {
                    let o = newton_offset(method, n);
                    let e = seen.entry(method.name()).or_insert([false; 5]);
                    e[0] |= w[o + 3] == 1.0;
                    e[1] |= w[o + 5] == 1.0;
                    e[3] |= w[o + 6] != 0.0;
                }
                let stats0 = ms[0].stats();
                for (i, &l) in lim[BEFORE..].iter().enumerate() {
                    step_all(&mut ms, c.sys.as_mut(), l, &format!("{what}, step {} after", i + 1));
                }
                let saved: Vec<Vec<u64>> = ms
                    .iter()
                    .map(|m| {
                        let mut w = Vec::new();
                        m.save_state(&mut w);
                        bits(&w)
                    })
                    .collect();
                assert!(
                    saved.iter().all(|w| *w == saved[0]),
                    "{what}: saved states after {AFTER} more steps"
                );
                if is_implicit(method) {
                    let e = seen.entry(method.name()).or_insert([false; 5]);
                    e[2] |= ms[0].stats().jac_evals > stats0.jac_evals;
                    e[4] |= ms[0].stats().rejected > stats0.rejected;
                }
            }
        }
    }
    for method in ["sdirk", "radau5"] {
        assert_eq!(
            seen[method],
            [true; 5],
            "{method}: (stale J saved, fresh J saved, J refreshed after a load, LU refactored on load, rejections after a load)"
        );
    }
}

/// A malformed state (truncated, lengthened, of another method or size, a flag that is
/// not 0 or 1, a counter that is not a whole number, a bad factorisation step size) is
/// refused, and the integrator is left as it was: it saves the same state and continues
/// bit for bit like the run it was loaded from.
#[test]
fn a_malformed_state_is_refused_and_changes_nothing() {
    for mut c in cases() {
        if !matches!(c.name, "smooth" | "van der pol" | "stiff cubic") {
            continue;
        }
        for method in Method::ALL {
            if c.implicit_only && method == Method::Rk4 {
                continue;
            }
            let s = SolverSection { method, ..c.s };
            let n = c.y0.len();
            let what = format!("{method:?} on {}", c.name);
            let lim = limits(c.seed * 16 + method as u64, 90 + AFTER);
            let mut a = create(&s, n);
            run_steps(a.as_mut(), &mut c, &lim[..40]);
            let (mut s1, mut s2) = (Vec::new(), Vec::new());
            a.save_state(&mut s1);
            let mut a2 = create(&s, n);
            run_steps(a2.as_mut(), &mut c, &lim[..90]);
            a2.save_state(&mut s2);
            let mut bad: Vec<(String, Vec<f64>)> = vec![
                ("empty".into(), vec![]),
                ("tag only".into(), s2[..1].to_vec()),
                ("one short".into(), s2[..s2.len() - 1].to_vec()),
                ("n short".into(), s2[..s2.len() - n].to_vec()),
                ("one more".into(), [&s2[..], &[0.0]].concat()),
                ("n more".into(), [&s2[..], &s2[1..=n]].concat()),
            ];
            let mut with = |name: String, i: usize, x: f64| {
                let mut v = s2.clone();
                v[i] = x;
                bad.push((name, v));
            };
            for m in Method::ALL.into_iter().filter(|&m| m != method) {
                with(format!("tag of {m:?}"), 0, m as i64 as f64);
            }
            with("tag NaN".into(), 0, f64::NAN);
            let (inner, base) = layout(method, &s2);
            if method == Method::Auto {
                // the switching memory: two flags, two counts, ρ, the Jacobian count
                // (−1: none), the switches; then the active method's tag
                for i in [1, 2] {
                    for x in [2.0, -1.0, 0.5, f64::NAN] {
                        with(format!("auto flag {i} = {x}"), i, x);
                    }
                }
                for i in [3, 4, 7] {
                    for x in [-1.0, 0.5, f64::NAN, f64::INFINITY, 2f64.powi(60)] {
                        with(format!("auto count {i} = {x}"), i, x);
                    }
                }
                for x in [-1.0, f64::NAN] {
                    with(format!("auto ρ = {x}"), 5, x);
                }
                for x in [-2.0, 0.5, f64::NAN] {
                    with(format!("auto Jacobian count = {x}"), 6, x);
                }
                with("auto with the other method's state".into(), 1, 1.0 - s2[1]);
                with("auto's inner tag".into(), base, Method::Sdirk as i64 as f64);
            }
            // counters: after the tag and t, t_prev, h
            for i in base + 4..base + 8 {
                for x in [-1.0, 0.5, f64::NAN, f64::INFINITY, 2f64.powi(60)] {
                    with(format!("counter {i} = {x}"), i, x);
                }
            }
            if is_implicit(inner) {
                let o = base + newton_offset(inner, n);
                let jac_valid = s2[o + 4] == 1.0;
                assert_eq!(
                    jac_valid,
                    c.name != "smooth" || method == Method::Auto,
                    "{what}: a Jacobian is held"
                );
                for i in o + 3..o + 6 {
                    for x in [2.0, -1.0, 0.5, f64::NAN] {
                        with(format!("flag {i} = {x}"), i, x);
                    }
                }
                // a Jacobian announced and missing, or not announced and present
                with("jac_valid flipped".into(), o + 4, if jac_valid { 0.0 } else { 1.0 });
                for x in [-1e-3, f64::NAN, f64::INFINITY] {
                    with(format!("LU step size {x}"), o + 6, x);
                }
                let mut warm = Vec::new();
                a2.warm_state(&mut warm);
                bad.push(("a warm state".into(), warm));
            }
            // the same method for another system size
            struct Rest;
            impl OdeSystem for Rest {
                fn rhs(&mut self, _t: f64, _y: &[f64], dy: &mut [f64]) {
                    dy.fill(0.0);
                }
            }
            let mut other_size = create(&s, n + 1);
            other_size.reset(&mut Rest, 0.0, &vec![1.0; n + 1], 0.0);
            let mut w = Vec::new();
            other_size.save_state(&mut w);
            bad.push(("system size n + 1".into(), w));

            let mut b = create(&s, n);
            b.load_state(&s1).unwrap();
            for (name, v) in &bad {
                let e = b.load_state(v);
                assert!(e.is_err(), "{what}: {name} was accepted");
                let mut w = Vec::new();
                b.save_state(&mut w);
                assert_eq!(bits(&w), bits(&s1), "{what}: refusing {name} changed the integrator");
            }
            assert!(bad.len() > 25, "{what}: {} malformed states", bad.len());
            let mut ms = [a, b];
            assert_same(ms[0].as_ref(), ms[1].as_ref(), &what);
            for (i, &l) in lim[90..].iter().enumerate() {
                step_all(&mut ms, c.sys.as_mut(), l, &format!("{what}, step {} after", i + 1));
            }
            // and the good state still loads
            ms[1].load_state(&s2).unwrap();
            assert_same(a2.as_ref(), ms[1].as_ref(), &what);
        }
    }
}

#[test]
fn newton_failures_in_a_burst_filter_the_starting_values() {
    let mut m = WarmMemory::cold();
    // a failure and its retries in one step: no burst
    m.note_newton_failure();
    m.note_newton_failure();
    assert_eq!(m.filtered_start, 0);
    // the next failure more than FAILURE_BURST_STEPS steps later: none either
    for _ in 0..=FAILURE_BURST_STEPS {
        m.note_accepted_step();
    }
    m.note_newton_failure();
    assert_eq!(m.filtered_start, 0);
    // within them: a burst
    for _ in 0..FAILURE_BURST_STEPS {
        m.note_accepted_step();
    }
    m.note_newton_failure();
    assert_eq!(m.filtered_start, FILTERED_START_STEPS);
    // it lasts FILTERED_START_STEPS accepted steps, a failure meanwhile renews it
    m.note_accepted_step();
    m.note_newton_failure();
    assert_eq!(m.filtered_start, FILTERED_START_STEPS);
    for left in (0..FILTERED_START_STEPS).rev() {
        m.note_accepted_step();
        assert_eq!(m.filtered_start, left);
    }
    // saved and read back as it was
    let mut v = Vec::new();
    m.note_newton_failure();
    m.write(&[], false, &mut v);
    assert_eq!(WarmMemory::read(&v, &mut [], 0, false), Ok(m));
}

/// A used integrator renewed for its own settings goes on as a new one, bit for bit (the
/// explicit methods, and `auto`, whose implicit method, built in the stiff cases, is dropped);
/// a renewal for another method, size or settings is refused and changes nothing; the
/// implicit methods do not renew.
#[test]
fn a_renewed_integrator_goes_on_as_a_new_one() {
    let saved = |m: &dyn Integrator| {
        let mut w = Vec::new();
        m.save_state(&mut w);
        bits(&w)
    };
    // (every method on every case, RK4 on the non-stiff ones)
    let runs = Method::ALL.into_iter().flat_map(|method| {
        let cases = cases().into_iter();
        cases.filter_map(move |c| (method != Method::Rk4 || !c.implicit_only).then_some((c, method)))
    });
    for (mut c, method) in runs {
        let (s, n) = (SolverSection { method, ..c.s.clone() }, c.y0.len());
        let what = format!("{method:?} on {}, renewed", c.name);
        let lim = limits(c.seed * 16 + method as u64, BEFORE);
        let mut used = create(&s, n);
        run_steps(used.as_mut(), &mut c, &lim[..BEFORE / 2]);
        let before = saved(used.as_ref());
        let other = |f: fn(&mut SolverSection)| {
            let mut o = s.clone();
            f(&mut o);
            o
        };
        let mut others = vec![
            (
                other(|o| {
                    o.method = if o.method == Method::Rk4 {
                        Method::Dopri5
                    } else {
                        Method::Rk4
                    }
                }),
                n,
            ),
            (other(|o| o.max_step *= 2.0), n),
            (s.clone(), n + 1),
        ];
        if method != Method::Rk4 {
            // (RK4 has no tolerances)
            others.push((other(|o| o.rtol *= 2.0), n));
        }
        for (o, size) in others {
            assert!(!used.renew(&o, size), "{what} for {o:?}, size {size}");
        }
        assert_eq!(
            saved(used.as_ref()),
            before,
            "{what}: a refused renewal changes nothing"
        );
        let renewed = used.renew(&s, n);
        assert_eq!(renewed, !is_implicit(method), "{what}");
        if !renewed {
            continue;
        }
        assert!(used.linear_stats().is_none(), "{what}: no implicit method");
        let mut new = create(&s, n);
        assert_eq!(saved(used.as_ref()), saved(new.as_ref()), "{what}: its state");
        run_steps(used.as_mut(), &mut c, &lim);
        run_steps(new.as_mut(), &mut c, &lim);
        assert_same(used.as_ref(), new.as_ref(), &what);
        assert_eq!(
            saved(used.as_ref()),
            saved(new.as_ref()),
            "{what}: after {BEFORE} steps"
        );
    }
}
