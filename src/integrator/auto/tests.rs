//! Tests of `auto`: switching on stiffness and on cost, the sparse path, saved states.

use super::super::radau::Radau5;
use super::super::test_problems::*;
use super::*;

/// Prothero-Robinson with a stiffness that fades: `y' = λ(t)(y − sin t) + cos t`,
/// `λ(t) = −10⁵ e^{−10t}`, `y = sin t` from `y(0) = 0`. Stiff at first (h·|λ| ≫ 3.3 at any
/// step the accuracy allows), not stiff after about t = 1 (|λ| < 5).
struct FadingStiffness;
impl OdeSystem for FadingStiffness {
    fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) {
        let lambda = -1e5 * (-10.0 * t).exp();
        dy[0] = lambda * (y[0] - t.sin()) + t.cos();
    }
}

fn auto(n: usize, rtol: f64) -> Auto<Radau5> {
    Auto::new(n, rtol, rtol, f64::INFINITY, Some(Radau5::new))
}

/// Steps to `t_end`, recording whether the implicit method was active after each step.
fn run_recording(m: &mut Auto<Radau5>, sys: &mut dyn OdeSystem, y0: &[f64], t_end: f64) -> Vec<(f64, bool)> {
    m.reset(sys, 0.0, y0, 0.0);
    let mut modes = Vec::new();
    while m.t() < t_end {
        m.step(sys, t_end).unwrap();
        modes.push((m.t(), m.is_stiff()));
    }
    modes
}

#[test]
fn the_spectral_radius_of_a_real_and_of_an_oscillating_dominant_mode() {
    let (mut x, mut jx) = (vec![0.0; 3], vec![0.0; 3]);
    let diag = [-5.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 1.0];
    let rho = spectral_radius(JacRef::Dense(&diag), &mut x, &mut jx);
    assert!((rho - 5.0).abs() < 1e-3, "{rho}");
    // x'' = −ω²x − c x' with light damping: eigenvalues −c/2 ± i√(ω² − c²/4), |λ| = ω
    let (mut x, mut jx) = (vec![0.0; 2], vec![0.0; 2]);
    let w = 1e4;
    let osc = [0.0, 1.0, -w * w, 0.0];
    let rho = spectral_radius(JacRef::Dense(&osc), &mut x, &mut jx);
    assert!((rho / w - 1.0).abs() < 1e-12, "{rho}");
    assert_eq!(spectral_radius(JacRef::Dense(&[0.0; 4]), &mut x, &mut jx), 0.0);
}

/// Stiff at first: auto switches to the implicit method within the first steps, then
/// back to Dormand-Prince once the stiffness has faded; it is as accurate as each method
/// alone and costs far fewer evaluations than Dormand-Prince (which sits at its stability
/// limit while stiff) and fewer than Radau IIA (whose steps each cost several).
#[test]
fn switches_to_the_implicit_method_while_stiff_and_back_when_the_stiffness_fades() {
    let rtol = 1e-7;
    let mut m = auto(1, rtol);
    let modes = run_recording(&mut m, &mut FadingStiffness, &[0.0], 3.0);
    assert_eq!(m.switches(), 2, "{modes:?}");
    let t_on = modes.iter().find(|(_, s)| *s).map(|(t, _)| *t).unwrap();
    let t_off = modes.iter().rev().find(|(_, s)| *s).map(|(t, _)| *t).unwrap();
    assert!(t_on < 1e-3, "switched to the implicit method at t = {t_on}");
    // stiff while 3.25/|λ(t)| is below the accuracy-limited step (~0.01 at this rtol)
    assert!((0.5..2.0).contains(&t_off), "switched back at t = {t_off}");
    assert!(!m.is_stiff());
    let err = (m.y()[0] - 3f64.sin()).abs();
    let mut d = Dopri5::new(1, rtol, rtol, f64::INFINITY);
    let yd = run(&mut d, &mut FadingStiffness, 0.0, &[0.0], 3.0);
    let mut r = Radau5::new(1, rtol, rtol, f64::INFINITY);
    let yr = run(&mut r, &mut FadingStiffness, 0.0, &[0.0], 3.0);
    let (ed, er) = ((yd[0] - 3f64.sin()).abs(), (yr[0] - 3f64.sin()).abs());
    assert!(err < 1e-6, "auto error {err:e} (dopri5 {ed:e}, radau5 {er:e})");
    let (sa, sd, sr) = (m.stats(), d.stats(), r.stats());
    println!("auto {sa:?}\ndopri5 {sd:?}\nradau5 {sr:?}");
    assert!(3 * sa.rhs_evals < sd.rhs_evals, "auto {sa:?}, dopri5 {sd:?}");
    assert!(sa.rhs_evals < sr.rhs_evals, "auto {sa:?}, radau5 {sr:?}");
}

/// A non-stiff problem never leaves Dormand-Prince: the steps are those of dopri5 alone,
/// bit for bit.
#[test]
fn a_non_stiff_problem_is_integrated_by_dormand_prince_alone() {
    let mut m = auto(3, 1e-8);
    let modes = run_recording(&mut m, &mut Smooth, &Smooth::exact(0.0), 5.0);
    assert!(modes.iter().all(|(_, s)| !s));
    let mut d = Dopri5::new(3, 1e-8, 1e-8, f64::INFINITY);
    let yd = run(&mut d, &mut Smooth, 0.0, &Smooth::exact(0.0), 5.0);
    assert_eq!(m.y(), &yd[..]);
    assert_eq!(m.stats(), d.stats());
}

/// A stiff oscillation that lasts (a resting contact): auto stays implicit once switched.
#[test]
fn a_lasting_stiff_oscillation_stays_implicit() {
    let mut sys = SpringDamper { omega: 1e4, g: 9.81 };
    let mut m = auto(2, 1e-8);
    let modes = run_recording(&mut m, &mut sys, &[0.0, -1.0], 1.0);
    assert_eq!(m.switches(), 1, "{:?}", &modes[..modes.len().min(40)]);
    assert!(m.is_stiff());
    let exact = sys.exact(1.0, -1.0);
    assert!(max_diff(m.y(), &exact) < 1e-9, "{:?} vs {exact:?}", m.y());
}

/// `n` copies of a stiff problem whose solution oscillates, `y' = λ(y − sin ωt) + ω cos ωt`
/// (`y = sin ωt`), λ = −10⁵, ω = 60: Dormand-Prince sits at its stability limit (3.3/|λ|),
/// and Radau IIA's steps, bounded by the accuracy of the oscillation, are some 30 times
/// longer, few enough that on the sparse path (n ≥ 200), where each factorisation counts
/// n evaluations, a stint on 1,000 states costs more than Dormand-Prince would.
struct FastOscillation;
const OMEGA: f64 = 60.0;
impl OdeSystem for FastOscillation {
    fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) {
        let (lambda, w) = (-1e5, OMEGA);
        for (d, v) in dy.iter_mut().zip(y) {
            *d = lambda * (v - (w * t).sin()) + w * (w * t).cos();
        }
    }
}

fn sparse_auto(n: usize) -> Auto<Radau5> {
    Auto::new(n, 1e-6, 1e-8, f64::INFINITY, Some(Radau5::new))
}

/// On the sparse path the stint's factorisations count toward its cost: the stint on
/// [`FastOscillation`] loses, auto switches back and holds Dormand-Prince (the cost it
/// remembers includes n evaluations per factorisation), a second loss in a row doubles
/// the hold, and a state saved in the middle of a stint continues bit for bit (the
/// factorisations before the save still count after the load).
#[test]
fn a_stint_that_costs_more_than_dormand_prince_switches_back_and_holds() {
    // (with 400 states the stint costs 1.7× Dormand-Prince, within the ratio: it stays)
    let n = 1000;
    let mut m = sparse_auto(n);
    let mut sys = FastOscillation;
    m.reset(&mut sys, 0.0, &vec![0.0; n], 0.0);
    let mut saved: Option<(Vec<f64>, f64)> = None;
    let mut first_loss = None;
    let t_end = 0.1;
    while m.t() < t_end {
        m.step(&mut sys, t_end).unwrap();
        if m.stiff && saved.is_none() && m.memory.steps_since_check == COST_WINDOW / 2 {
            let mut w = Vec::new();
            m.save_state(&mut w);
            assert!(w[14] > 0.0, "the stint's factorisations are saved: {}", w[14]);
            saved = Some((w, m.t()));
        }
        if m.memory.losses == 1 && first_loss.is_none() {
            let lw = m.implicit.as_ref().map_or(0.0, linear_work);
            assert!(lw > 0.0);
            first_loss = Some((m.memory.implicit_cost, m.memory.cost_hold));
        }
    }
    let (cost, hold) = first_loss.expect("the stint lost");
    assert_eq!(hold, COST_MEMORY_STEPS);
    // Dormand-Prince at its stability limit: 6 evaluations per 3.3/|λ|
    let explicit = DOPRI5_EVALUATIONS * 1e5 / STABILITY_BOUNDARY;
    assert!(
        cost > COST_RATIO * explicit * 0.9,
        "remembered cost {cost:e}, Dormand-Prince {explicit:e}"
    );
    assert!(m.switches() >= 2, "{}", m.switches());
    assert!(m.memory.losses >= 1);
    let err = (m.y()[0] - (OMEGA * m.t()).sin()).abs();
    assert!(err < 1e-4, "{err:e}");

    // from the state saved in the middle of the first stint: the same run
    let (w, t_saved) = saved.expect("a stint");
    let mut again = sparse_auto(n);
    again.load_state(&w).unwrap();
    let mut reference = sparse_auto(n);
    reference.reset(&mut sys, 0.0, &vec![0.0; n], 0.0);
    while reference.t() < t_saved {
        reference.step(&mut sys, t_end).unwrap();
    }
    assert_eq!(reference.t(), t_saved);
    while reference.t() < t_end {
        reference.step(&mut sys, t_end).unwrap();
        again.step(&mut sys, t_end).unwrap();
        assert_eq!(
            (again.t(), again.stiff, again.memory.losses),
            (reference.t(), reference.stiff, reference.memory.losses)
        );
    }
    assert_eq!(again.y(), reference.y());
    assert_eq!(again.switches(), m.switches());
}

/// auto on [`FadingStiffness`] run until it switched to the implicit method.
fn stiff_auto() -> Auto<Radau5> {
    let mut m = auto(1, 1e-7);
    m.reset(&mut FadingStiffness, 0.0, &[0.0], 0.0);
    while !m.stiff {
        m.step(&mut FadingStiffness, 1.0).unwrap();
    }
    m
}

/// A switch back for cost stands across a reset (an event does not undo the stint's
/// spending); a switch asked for by stiffness alone does not. An island formed anew
/// takes over the hold of the islands it came from, the longest and costliest of them.
#[test]
fn a_switch_back_for_cost_stands_across_a_reset_and_its_hold_passes_on() {
    let (mut sys, mut m) = (FadingStiffness, stiff_auto());
    let y = m.y().to_vec();
    m.switch_pending = true;
    m.reset(&mut sys, m.t(), &y, 0.0);
    assert!(!m.switch_pending, "a calm switch is dropped at a reset");
    m.switch_pending = true;
    m.memory.cost_hold = COST_MEMORY_STEPS;
    m.reset(&mut sys, m.t(), &y, 0.0);
    assert!(m.switch_pending, "a switch for cost stands");
    m.step(&mut sys, 1.0).unwrap();
    assert!(!m.stiff);
    let held = m.explicit_hold().expect("a hold");
    assert_eq!(held.steps, COST_MEMORY_STEPS - 1);

    let mut fresh = auto(1, 1e-7);
    assert_eq!(fresh.explicit_hold(), None);
    let a = ExplicitHold {
        implicit_cost: 10.0,
        steps: 100,
        losses: 1,
    };
    let b = ExplicitHold {
        implicit_cost: 5.0,
        steps: 300,
        losses: 2,
    };
    let joined = a.join(b);
    assert_eq!(
        joined,
        ExplicitHold {
            implicit_cost: 10.0,
            steps: 300,
            losses: 2
        }
    );
    fresh.hold_explicit(joined);
    assert_eq!(fresh.explicit_hold(), Some(joined));
    fresh.hold_explicit(a);
    assert_eq!(fresh.explicit_hold(), Some(joined), "a shorter hold is not taken");
    m.stiff = true;
    m.memory.cost_hold = 0;
    m.hold_explicit(joined);
    assert_eq!(m.memory.cost_hold, 0, "an active implicit method takes no hold");
}

/// A large stiff system (above the dense threshold of [`super::super::linear`]) switches
/// to the implicit method on its sparse path, with ρ(J) from the sparse Jacobian, and meets
/// the tolerance; without an implicit method auto stays with Dormand-Prince (at its
/// stability limit) and refuses a state that claims the implicit one.
#[test]
fn a_large_stiff_system_switches_to_the_sparse_implicit_method() {
    struct Many(FadingStiffness);
    impl OdeSystem for Many {
        fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) {
            for (d, v) in dy.iter_mut().zip(y) {
                let mut one = [0.0];
                self.0.rhs(t, &[*v], &mut one);
                *d = one[0];
            }
        }
    }
    let n = 300;
    let s = crate::scene::SolverSection {
        method: Method::Auto,
        rtol: 1e-6,
        atol: 1e-8,
        ..Default::default()
    };
    let mut m = super::super::create(&s, n);
    let mut many = Many(FadingStiffness);
    m.reset(&mut many, 0.0, &vec![0.0; n], 0.0);
    let mut was_stiff = false;
    while m.t() < 0.02 {
        m.step(&mut many, 0.02).unwrap();
        let mut w = Vec::new();
        m.save_state(&mut w);
        was_stiff |= w[1] == 1.0;
    }
    assert!(was_stiff, "{:?}", m.stats());
    // the stint's start (a probe of n + 1 evaluations) is paid back: it does not lose
    // at its early check, and the run takes a few dozen steps
    assert_eq!(m.explicit_hold(), None);
    assert!(m.stats().steps < 30, "{:?}", m.stats());
    assert!((m.y()[n - 1] - 0.02f64.sin()).abs() < 1e-5);
    let ls = m.linear_stats().expect("an implicit method");
    assert!(ls.sparse, "{ls:?}");

    let mut alone: Auto<Radau5> = Auto::new(n, 1e-6, 1e-8, f64::INFINITY, None);
    let y = run(&mut alone, &mut many, 0.0, &vec![0.0; n], 0.02);
    assert!((y[0] - 0.02f64.sin()).abs() < 1e-5);
    assert!(
        alone.stats().steps > 100,
        "{:?}: stability-limited steps",
        alone.stats()
    );
    let mut w = Vec::new();
    alone.save_state(&mut w);
    assert_eq!(w[1], 0.0, "explicit throughout");
    w[1] = 1.0;
    assert!(alone.load_state(&w).is_err());
    assert!(alone.linear_stats().is_none());
}

/// A saved switching memory that no run makes is refused: a hold in a stint without the
/// switch back pending, a hold longer than the longest, a remembered cost that is not finite.
#[test]
fn a_switching_memory_no_run_makes_is_refused() {
    let m = stiff_auto();
    let mut w = Vec::new();
    m.save_state(&mut w);
    // (after the tag: stiff, pending, ..., the remembered cost at 16, the hold at 17)
    assert_eq!((w[1], w[2], w[17]), (1.0, 0.0, 0.0));
    let loads = |w: &[f64]| auto(1, 1e-7).load_state(w).is_ok();
    assert!(loads(&w));
    let mut bad = w.clone();
    bad[16] = 1e5;
    bad[17] = COST_MEMORY_STEPS as f64;
    assert!(!loads(&bad), "a hold in a stint without the switch back pending");
    bad[2] = 1.0;
    assert!(loads(&bad), "with it pending: a stint that lost");
    bad[17] = (COST_MEMORY_STEPS << MAX_HOLD_DOUBLINGS) as f64 + 1.0;
    assert!(!loads(&bad), "a hold longer than the longest");
    bad[17] = COST_MEMORY_STEPS as f64;
    bad[16] = f64::INFINITY;
    assert!(!loads(&bad), "a remembered cost that is not finite");
}
