//! Preallocated work arrays of the impulse law (sized at compilation, so that resolving
//! impacts allocates nothing). The computations that use them are in the contact module (`impulse.rs`).

/// The loop-only projection `G`: the factor of `Φ_l M̄⁻¹ Φ_lᵀ` over the `nl` loop rows, with
/// its own solve buffers (sized once).
#[derive(Debug, Clone, Default)]
pub(crate) struct Projection {
    pub(crate) nl: usize,
    pub(crate) schur: Vec<f64>,
    pub(crate) perm: Vec<usize>,
    pub(crate) rank: usize,
    pub(crate) b: Vec<f64>,
    pub(crate) work: Vec<f64>,
}

impl Projection {
    pub(crate) fn with_rows(nl: usize) -> Projection {
        let mut p = Projection::default();
        p.refit(nl);
        p
    }

    /// Makes these buffers what [`Projection::with_rows`]`(nl)` gives, reusing them.
    fn refit(&mut self, nl: usize) {
        (self.nl, self.rank) = (nl, 0);
        filled(&mut self.schur, nl * nl, 0.0);
        filled(&mut self.perm, nl, 0);
        filled(&mut self.b, nl, 0.0);
        filled(&mut self.work, nl, 0.0);
    }
}

/// Work arrays of [`solve_lcp_with`] for problems of up to `n` contacts.
///
/// [`solve_lcp_with`]: crate::contact::impulse::solve_lcp_with
#[derive(Debug, Clone, Default)]
pub struct LcpWork {
    pub(crate) n: usize,
    pub(crate) active: Vec<bool>,
    pub(crate) idx: Vec<usize>,
    pub(crate) p: Vec<f64>,
    pub(crate) a: Vec<f64>,
    pub(crate) rhs: Vec<f64>,
    pub(crate) perm: Vec<usize>,
    pub(crate) work: Vec<f64>,
    pub(crate) wv: Vec<f64>,
}

impl LcpWork {
    /// Buffers for problems of up to `n` unknowns.
    pub fn new(n: usize) -> LcpWork {
        let mut w = LcpWork::default();
        w.refit(n);
        w
    }

    /// Makes these buffers what [`LcpWork::new`]`(n)` gives, reusing them.
    fn refit(&mut self, n: usize) {
        self.n = n;
        filled(&mut self.active, n, false);
        emptied(&mut self.idx, n);
        filled(&mut self.perm, n, 0);
        filled(&mut self.a, n * n, 0.0);
        for v in [&mut self.p, &mut self.rhs, &mut self.work, &mut self.wv] {
            filled(v, n, 0.0);
        }
    }

    /// Grows the buffers (allocates) only if `n` exceeds the size they were made for.
    pub(crate) fn reserve(&mut self, n: usize) {
        if n > self.n {
            *self = LcpWork::new(n);
        }
    }
}

/// Work arrays of the friction impulses of a round of up to `k` contacts (see
/// `impulse::friction_impulses`).
#[derive(Debug, Clone, Default)]
pub(crate) struct FrictionWork {
    /// The contacts of the round that have friction (positions in the round).
    pub(crate) fric: Vec<usize>,
    /// Their tangent rows `T` (two per contact, 2k × nv) and images `G Tᵀ` (2k × nv).
    pub(crate) trows: Vec<f64>,
    pub(crate) gt: Vec<f64>,
    /// `W_tt = T G Tᵀ` (2k × 2k), the tangential velocities after the normal impulses (2k),
    /// the tangential impulses (2k).
    pub(crate) wtt: Vec<f64>,
    pub(crate) bt: Vec<f64>,
    pub(crate) pt: Vec<f64>,
}

impl FrictionWork {
    /// Makes these buffers those of rounds of up to `k` contacts in a model with `nv`
    /// velocities, reusing them.
    fn refit(&mut self, nv: usize, k: usize) {
        let FrictionWork {
            fric,
            trows,
            gt,
            wtt,
            bt,
            pt,
        } = self;
        emptied(fric, k);
        filled(trows, 2 * k * nv, 0.0);
        filled(gt, 2 * k * nv, 0.0);
        filled(wtt, 4 * k * k, 0.0);
        filled(bt, 2 * k, 0.0);
        filled(pt, 2 * k, 0.0);
    }
}

/// Preallocated work arrays of the impulse law: everything [`resolve_with`] needs for rounds
/// of up to `k` simultaneous impacts of a model with `nv` velocities (and its loop rows), so
/// that resolving an impact allocates nothing. Sized when the engine is compiled.
///
/// [`resolve_with`]: crate::contact::impulse::resolve_with
#[derive(Debug, Clone, Default)]
pub struct ImpulseWork {
    pub(crate) k: usize,
    pub(crate) nv: usize,
    pub(crate) proj: Projection,
    /// Separation-rate rows `J` (k × nv).
    pub(crate) jrows: Vec<f64>,
    /// Their images `G Jᵀ` (k × nv).
    pub(crate) gj: Vec<f64>,
    pub(crate) qvel: Vec<f64>,
    pub(crate) rate: Vec<f64>,
    pub(crate) impulses: Vec<f64>,
    /// Rows solved exactly (the rest use the effective mass).
    pub(crate) exact: Vec<usize>,
    pub(crate) w: Vec<f64>,
    pub(crate) q: Vec<f64>,
    pub(crate) p: Vec<f64>,
    pub(crate) lcp: LcpWork,
    /// Friction impulses.
    pub(crate) friction: FrictionWork,
    /// Effective-mass buffers (nv each).
    pub(crate) row: Vec<f64>,
    pub(crate) free: Vec<f64>,
    pub(crate) x: Vec<f64>,
    /// Contacts of the last round.
    pub(crate) last: usize,
}

impl ImpulseWork {
    /// Buffers for up to `k` simultaneous impacts in a model with `nv` velocities and `nl`
    /// loop-constraint rows.
    pub fn new(nv: usize, nl: usize, k: usize) -> ImpulseWork {
        let mut w = ImpulseWork::default();
        w.refit(nv, nl, k);
        w
    }

    /// Makes these buffers what [`ImpulseWork::new`]`(nv, nl, k)` gives, reusing them (they
    /// allocate only where they are too small). (`Data`'s test `refitted_data_equals_new_data`
    /// compares every field.) For no contacts (`k` 0) every buffer is empty: a round of no
    /// impacts reads none, and a round of some makes them anew ([`ImpulseWork::reserve`]).
    pub(crate) fn refit(&mut self, nv: usize, nl: usize, k: usize) {
        (self.k, self.nv, self.last) = (k, nv, 0);
        let (nv, nl) = if k == 0 { (0, 0) } else { (nv, nl) };
        self.proj.refit(nl);
        for (v, n) in [
            (&mut self.jrows, k * nv),
            (&mut self.gj, k * nv),
            (&mut self.qvel, nv),
            (&mut self.rate, k),
            (&mut self.impulses, k),
            (&mut self.w, k * k),
            (&mut self.q, k),
            (&mut self.p, k),
            (&mut self.row, nv),
            (&mut self.free, nv),
            (&mut self.x, nv),
        ] {
            filled(v, n, 0.0);
        }
        emptied(&mut self.exact, k);
        self.lcp.refit(k);
        self.friction.refit(nv, k);
    }

    /// Normal impulse of each contact of the last [`resolve_with`] round, in the order given
    /// \[N s\].
    ///
    /// [`resolve_with`]: crate::contact::impulse::resolve_with
    pub fn impulses(&self) -> &[f64] {
        &self.impulses[..self.last]
    }

    /// Tangential (friction) impulse of each contact of the last round, along its two tangent
    /// directions (the contact module's friction tangents of the normal) \[N s\]; zero for a
    /// contact without friction.
    pub fn friction_impulse(&self, k: usize) -> [f64; 2] {
        let f = &self.friction;
        match f.fric.iter().position(|&r| r == k) {
            Some(a) if k < self.last => [f.pt[2 * a], f.pt[2 * a + 1]],
            _ => [0.0; 2],
        }
    }

    /// Makes the buffers fit `k` contacts of a model with `nv` velocities and `nl` loop rows
    /// (allocates only if they do not).
    pub(crate) fn reserve(&mut self, nv: usize, nl: usize, k: usize) {
        if k > self.k || self.nv != nv || self.proj.nl != nl {
            *self = ImpulseWork::new(nv, nl, k.max(self.k));
        }
    }
}

/// Sets `v` to `n` copies of `x`, keeping its buffer (it allocates only when too small).
pub(crate) fn filled<T: Clone>(v: &mut Vec<T>, n: usize, x: T) {
    v.clear();
    v.resize(n, x);
}

/// Empties `v` and makes room for `n` entries, keeping its buffer.
pub(crate) fn emptied<T>(v: &mut Vec<T>, n: usize) {
    v.clear();
    v.reserve(n);
}
