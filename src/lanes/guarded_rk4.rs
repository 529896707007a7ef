//! The guarded RK4 control step on lanes: tension-form derivative, classical RK4,
//! projection onto the constraints and the failure guard, each a transcription of
//! the scalar code ([`crate::model::Chain::derivative`], the rk4 integrator,
//! [`crate::model::Chain::project`], [`crate::integrate::GuardedStepper`]) with the same
//! operations in the same order. Everything here is `#[inline(always)]`: it is
//! compiled into each dispatched kernel in [`super::dispatch`].

// Index loops on purpose: `copy_from_slice` and iterator adaptors are not always
// inlined, and whatever is not inlined runs as baseline code.
#![allow(clippy::needless_range_loop, clippy::manual_memcpy)]

use super::lane_vectors::{LaneGeometry, LaneVector};
use super::params::LaneParams;
use super::simd::{flat, flat_mut, is_dense, LaneReal, Lanes};
use crate::geometry::Layout;
use crate::integrate::{swept_per_step, swept_surely_within, Guard, StepStatus};

/// The per-link rows of the tension system of one derivative evaluation.
#[derive(Debug, Clone)]
struct Sweep<G: LaneGeometry<L, T>, const L: usize, T: LaneReal = f64> {
    q: Vec<G::LinkL>,
    /// Eliminated super-diagonal.
    off: Vec<Lanes<L, T>>,
    /// Eliminated right-hand side, then the tensions.
    tension: Vec<Lanes<L, T>>,
}

/// Buffers of one lane group, allocated once.
#[derive(Debug, Clone)]
pub struct LaneWorkspace<G: LaneGeometry<L, T>, const L: usize, T: LaneReal = f64> {
    pub(crate) lay: Layout<G>,
    sweep: Sweep<G, L, T>,
    stages: [Vec<Lanes<L, T>>; 4],
    trial: Vec<Lanes<L, T>>,
    /// State at the start of the control period (the guard compares against it, and
    /// a lane that must not move is restored from it).
    start: Vec<Lanes<L, T>>,
    pub(crate) force: G::CartL,
}

impl<G: LaneGeometry<L, T>, const L: usize, T: LaneReal> LaneWorkspace<G, L, T> {
    /// Buffers for `n` links.
    pub fn new(n: usize) -> Self {
        let lay = Layout::<G>::new(n);
        let v = || vec![Lanes::zero(); lay.dim()];
        Self {
            lay,
            sweep: Sweep {
                q: vec![G::LinkL::zero(); n],
                off: vec![Lanes::zero(); n],
                tension: vec![Lanes::zero(); n],
            },
            stages: [v(), v(), v(), v()],
            trial: v(),
            start: v(),
            force: G::CartL::zero(),
        }
    }
}

/// What one control step needs besides the buffers.
#[derive(Debug, Clone, Copy)]
pub struct StepSpec<'a, const L: usize, T: LaneReal = f64> {
    /// The lanes' parameters.
    pub params: &'a LaneParams<L, T>,
    /// Control period (s).
    pub dt: f64,
    /// Integrator steps per control period.
    pub substeps: usize,
    /// When a step counts as failed.
    pub guard: &'a Guard,
}

/// Link `i`'s direction in the lanes of `y`.
#[inline(always)]
fn load_q<G: LaneGeometry<L, T>, const L: usize, T: LaneReal>(
    lay: Layout<G>,
    y: &[Lanes<L, T>],
    i: usize,
) -> G::LinkL {
    G::LinkL::load(y, lay.q(i))
}

/// Forward sweep of the tension system (one row built and eliminated per link);
/// writes `qdot_i` into `dy` and leaves the eliminated rows in the workspace.
#[inline(always)]
fn forward_sweep<G: LaneGeometry<L, T>, const L: usize, T: LaneReal>(
    p: &LaneParams<L, T>,
    lay: Layout<G>,
    y: &[Lanes<L, T>],
    force: G::CartL,
    sweep: &mut Sweep<G, L, T>,
    dy: &mut [Lanes<L, T>],
) {
    let (q_buf, off_buf, tension) = (&mut sweep.q, &mut sweep.off, &mut sweep.tension);
    let one = Lanes::splat(T::ONE);
    let mut pivot_inv = Lanes::zero();
    for i in 0..lay.n {
        let q = load_q(lay, y, i);
        let qdot = G::lanes_velocity(G::SpinL::load(y, lay.w(i)), q);
        q_buf[i] = q;
        qdot.store(dy, lay.q(i));
        let mut rhs = p.lengths[i] * qdot.norm_squared();
        let diag;
        if i == 0 {
            let h = G::lanes_horizontal(q);
            diag = p.inv_masses[0] + h.norm_squared() * p.inv_cart_mass;
            rhs = rhs
                + (p.gravity * G::lanes_down(q) - q.dot(G::lanes_lift(force)) * p.inv_cart_mass);
        } else {
            let off = -q_buf[i - 1].dot(q) * p.inv_masses[i - 1];
            let c = off * pivot_inv;
            off_buf[i - 1] = c;
            diag = p.inv_masses[i] + p.inv_masses[i - 1] - off * c;
            rhs = rhs - off * tension[i - 1];
        }
        pivot_inv = one / diag;
        tension[i] = rhs * pivot_inv;
    }
}

/// `dy = [xdot, xdd, qdot_1..n, wdot_1..n]` for every lane.
#[inline(always)]
fn derivative<G: LaneGeometry<L, T>, const L: usize, T: LaneReal>(
    p: &LaneParams<L, T>,
    lay: Layout<G>,
    y: &[Lanes<L, T>],
    force: G::CartL,
    sweep: &mut Sweep<G, L, T>,
    dy: &mut [Lanes<L, T>],
) {
    forward_sweep(p, lay, y, force, sweep, dy);
    let (q_buf, off_buf, tension) = (&sweep.q, &sweep.off, &mut sweep.tension);
    let n = lay.n;
    // Back substitution from the free end, where T_{n+1} = 0.
    let mut t_next = Lanes::zero();
    let mut acc_next = G::LinkL::zero();
    for i in (0..n).rev() {
        let t = if i + 1 < n {
            tension[i] - off_buf[i] * t_next
        } else {
            tension[i]
        };
        tension[i] = t;
        let mut acc = q_buf[i] * (-t);
        if i + 1 < n {
            acc = acc + q_buf[i + 1] * t_next;
        }
        acc = acc * p.inv_masses[i];
        if i + 1 < n {
            let qdd = (acc_next - acc) * p.inv_lengths[i + 1];
            G::lanes_spin(q_buf[i + 1], qdd).store(dy, lay.w(i + 1));
        }
        acc_next = acc;
        t_next = t;
    }
    let xdd = (force + G::lanes_horizontal(q_buf[0]) * t_next) * p.inv_cart_mass;
    G::CartL::load(y, lay.xdot()).store(dy, lay.x());
    xdd.store(dy, lay.xdot());
    let qdd = (acc_next - G::lanes_lift(xdd) + G::lanes_down_unit() * p.gravity) * p.inv_lengths[0];
    G::lanes_spin(q_buf[0], qdd).store(dy, lay.w(0));
}

/// `out = a + c * b`, per component and lane.
#[inline(always)]
fn axpy<const L: usize, T: LaneReal>(
    out: &mut [Lanes<L, T>],
    a: &[Lanes<L, T>],
    c: f64,
    b: &[Lanes<L, T>],
) {
    let c = T::from_f64(c);
    if is_dense::<L, T>() {
        let (out, a, b) = (flat_mut(out), flat(a), flat(b));
        let m = out.len().min(a.len()).min(b.len());
        for j in 0..m {
            out[j] = a[j] + c * b[j];
        }
    } else {
        for j in 0..out.len() {
            out[j] = a[j] + Lanes::splat(c) * b[j];
        }
    }
}

/// `y += c (k1 + 2 (k2 + k3) + k4)`, per component and lane.
#[inline(always)]
fn rk4_combine<const L: usize, T: LaneReal>(y: &mut [Lanes<L, T>], c: f64, k: [&[Lanes<L, T>]; 4]) {
    let (c, two) = (T::from_f64(c), T::from_f64(2.0));
    if is_dense::<L, T>() {
        let y = flat_mut(y);
        let (k1, k2, k3, k4) = (flat(k[0]), flat(k[1]), flat(k[2]), flat(k[3]));
        let m = y
            .len()
            .min(k1.len())
            .min(k2.len())
            .min(k3.len())
            .min(k4.len());
        for j in 0..m {
            y[j] = y[j] + c * (k1[j] + two * (k2[j] + k3[j]) + k4[j]);
        }
    } else {
        let [k1, k2, k3, k4] = k;
        let (c, two) = (Lanes::splat(c), Lanes::splat(two));
        for j in 0..y.len() {
            y[j] = y[j] + c * (k1[j] + two * (k2[j] + k3[j]) + k4[j]);
        }
    }
}

/// One classical RK4 step of size `h` followed by the projection onto the constraints.
#[inline(always)]
fn rk4_substep<G: LaneGeometry<L, T>, const L: usize, T: LaneReal>(
    p: &LaneParams<L, T>,
    ws: &mut LaneWorkspace<G, L, T>,
    y: &mut [Lanes<L, T>],
    h: f64,
) {
    let lay = ws.lay;
    let force = ws.force;
    let [k1, k2, k3, k4] = &mut ws.stages;
    let sw = &mut ws.sweep;
    let tmp = &mut ws.trial[..];
    derivative(p, lay, y, force, sw, k1);
    axpy(tmp, y, 0.5 * h, k1);
    derivative(p, lay, tmp, force, sw, k2);
    axpy(tmp, y, 0.5 * h, k2);
    derivative(p, lay, tmp, force, sw, k3);
    axpy(tmp, y, h, k3);
    derivative(p, lay, tmp, force, sw, k4);
    rk4_combine(y, h / 6.0, [k1, k2, k3, k4]);
    project(lay, y);
}

/// Restores `|q_i| = 1` and `w_i . q_i = 0`.
#[inline(always)]
fn project<G: LaneGeometry<L, T>, const L: usize, T: LaneReal>(
    lay: Layout<G>,
    y: &mut [Lanes<L, T>],
) {
    let one = Lanes::splat(T::ONE);
    for i in 0..lay.n {
        // Both loads before both stores: storing q first made LLVM copy w through
        // the stack in odd pieces and stall reading it back (store forwarding).
        let q = load_q(lay, y, i);
        let w = G::SpinL::load(y, lay.w(i));
        let q = q * (one / q.norm_squared().sqrt());
        let w = G::lanes_tangent(w, q);
        q.store(y, lay.q(i));
        w.store(y, lay.w(i));
    }
}

/// Advances the lane group `y` (component-major: `y[j].0[k]` is component j of lane
/// k) by one control period under `ws.force` and returns each lane's status. Lanes
/// that failed hold garbage in `y`: the caller keeps their old state, or gets it back
/// with [`roll_back`].
#[inline(always)]
pub fn guarded_rk4<G: LaneGeometry<L, T>, const L: usize, T: LaneReal>(
    spec: StepSpec<'_, L, T>,
    ws: &mut LaneWorkspace<G, L, T>,
    y: &mut [Lanes<L, T>],
) -> [StepStatus; L] {
    let y = &mut y[..ws.lay.dim()];
    for j in 0..y.len().min(ws.start.len()) {
        ws.start[j] = y[j];
    }
    let h = spec.dt / spec.substeps as f64;
    for _ in 0..spec.substeps {
        rk4_substep(spec.params, ws, y, h);
    }
    classify(spec, ws, y)
}

/// Puts the lanes with `keep[k]` of `y` back where the last [`guarded_rk4`] on `ws`
/// started them (a failed env keeps its last good state, an env that was not to step
/// does not move), leaving every other lane as it is.
#[inline(always)]
pub(crate) fn roll_back<G: LaneGeometry<L, T>, const L: usize, T: LaneReal>(
    ws: &LaneWorkspace<G, L, T>,
    y: &mut [Lanes<L, T>],
    keep: &[bool; L],
) {
    for j in 0..y.len().min(ws.start.len()) {
        let start = &ws.start[j];
        for k in 0..L {
            if keep[k] {
                y[j].0[k] = start.0[k];
            }
        }
    }
}

/// The scalar guard's verdict per lane: non-finite, then constraint violation, then
/// a turn per step too large to resolve.
#[inline(always)]
fn classify<G: LaneGeometry<L, T>, const L: usize, T: LaneReal>(
    spec: StepSpec<'_, L, T>,
    ws: &LaneWorkspace<G, L, T>,
    y: &[Lanes<L, T>],
) -> [StepStatus; L] {
    let (lay, start) = (ws.lay, &ws.start[..]);
    // `v - v` is 0 for a finite v and NaN otherwise; the sum is an ordered
    // floating-point reduction, which also keeps LLVM from gathering across lanes.
    let mut poison = Lanes::zero();
    for &v in y {
        poison = poison + nan_unless_finite(v);
    }
    let finite = poison.finite_mask();
    let one = Lanes::splat(T::ONE);
    let (mut unit, mut chord2, mut spin2) = (Lanes::zero(), Lanes::zero(), Lanes::zero());
    for i in 0..lay.n {
        let q = load_q(lay, y, i);
        unit = unit.max((q.norm_squared().sqrt() - one).abs());
        chord2 = chord2.max((q - load_q(lay, start, i)).norm_squared());
        spin2 = spin2.max(G::SpinL::load(y, lay.w(i)).norm_squared());
    }
    let violated = unit.greater_mask(Lanes::splat_f64(spec.guard.unit_length_tolerance));
    let substeps = spec.substeps as f64;
    let spin_turn = spin2.sqrt() * Lanes::splat_f64(spec.dt) / Lanes::splat_f64(substeps);
    let max_turn = spec.guard.max_turn_per_step;
    let chord = chord2.sqrt();
    let mut status = [StepStatus::Ok; L];
    if all_resolved(finite, violated, spin_turn, chord, substeps, max_turn) {
        return status;
    }
    for k in 0..L {
        status[k] = if !finite[k] {
            StepStatus::NonFinite
        } else if violated[k] {
            StepStatus::ConstraintViolation
        } else if spin_turn.0[k].to_f64().max(swept_per_step(
            chord.0[k].to_f64(),
            substeps,
            max_turn,
        )) > max_turn
        {
            StepStatus::Unresolved
        } else {
            StepStatus::Ok
        };
    }
    status
}

/// Whether every lane passes the guard with the `asin` of [`swept_per_step`] skipped:
/// finite, within the unit-length tolerance, spin within `max_turn` and the swept
/// angle's cheap bound within it too. Then each lane's verdict is `Ok`, exactly as the
/// per-lane test would find (which still decides every other case). Branch-free over
/// the lanes, so it compiles to a few packed compares instead of `L` branchy verdicts.
#[inline(always)]
fn all_resolved<const L: usize, T: LaneReal>(
    finite: [bool; L],
    violated: [bool; L],
    spin_turn: Lanes<L, T>,
    chord: Lanes<L, T>,
    substeps: f64,
    max_turn: f64,
) -> bool {
    let bound = max_turn * substeps;
    let mut ok = true;
    for k in 0..L {
        let cheap = swept_surely_within(chord.0[k].to_f64(), bound);
        ok &= finite[k] & !violated[k] & (spin_turn.0[k].to_f64() <= max_turn) & cheap;
    }
    ok
}

/// `v - v`: 0 where v is finite, NaN where it is infinite or NaN.
#[inline(always)]
#[allow(clippy::eq_op)]
fn nan_unless_finite<const L: usize, T: LaneReal>(v: Lanes<L, T>) -> Lanes<L, T> {
    v - v
}
