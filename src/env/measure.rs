//! What the task reads of a state (distances to the target equilibrium, the cart's
//! offset and speed, and the reward they give with the squared action), computed one
//! state at a time or for a whole lane group at once right after its step (the
//! lanes' [`AfterStep`] hook), with the same operations in the same order, so both
//! give the same bits. Lanes of any width and number type are measured eight at a
//! time in f64 (f32 lanes widened exactly as they are read), as the scalar code
//! measures the f64 state.

// Index loops on purpose: they must inline into the dispatched kernels.
#![allow(clippy::needless_range_loop)]

use super::config::RewardWeights;
use crate::geometry::{Geometry, Layout, Vector};
use crate::lanes::exp::exp;
use crate::lanes::simd::{LaneReal, Lanes};
use crate::lanes::vector::{LaneGeometry, LaneVector};
use crate::lanes::{room, AfterStep, LANES};

/// The quantities of one state the task's reward, termination and success read.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StateMeasure {
    /// `sum_i |q_i - s_i e3|^2`.
    pub q2: f64,
    /// `sum_i |w_i|^2`.
    pub w2: f64,
    /// `e_q = sum_i |q_i - s_i e3|`.
    pub e_q: f64,
    /// `e_w = sum_i |w_i|`.
    pub e_w: f64,
    /// `|x|^2`, the cart's squared offset.
    pub x2: f64,
    /// `|xdot|^2`.
    pub v2: f64,
    /// The largest `|x_k|` over the cart's axes.
    pub x_max: f64,
    /// The reward of a step that reached this state ([`reward`]).
    pub reward: f64,
}

/// The reward `exp(-(w_q q2 + w_w w2 + w_x x2 + w_v v2 + w_u a2))` of a state with these
/// measures reached by an action whose squared norm is `a2`.
#[inline(always)]
pub fn reward(w: &RewardWeights, q2: f64, w2: f64, x2: f64, v2: f64, a2: f64) -> f64 {
    exp(-(w.q * q2 + w.w * w2 + w.x * x2 + w.v * v2 + w.u * a2))
}

/// [`StateMeasure`]s of many envs, one array per quantity: the lanes of a group are
/// stored whole (written per env as a struct, LLVM vectorised the measuring across
/// the quantities instead of along the lanes).
#[derive(Debug, Clone, Default)]
pub struct Measures {
    q2: Vec<f64>,
    w2: Vec<f64>,
    e_q: Vec<f64>,
    e_w: Vec<f64>,
    x2: Vec<f64>,
    v2: Vec<f64>,
    x_max: Vec<f64>,
    reward: Vec<f64>,
}

impl Measures {
    /// Room for `num_envs` envs, rounded up to whole lane groups of any width.
    pub fn new(num_envs: usize) -> Self {
        let v = || vec![0.0; room(num_envs)];
        Self {
            q2: v(),
            w2: v(),
            e_q: v(),
            e_w: v(),
            x2: v(),
            v2: v(),
            x_max: v(),
            reward: v(),
        }
    }

    /// Env `k`'s measures.
    #[inline(always)]
    pub fn get(&self, k: usize) -> StateMeasure {
        StateMeasure {
            q2: self.q2[k],
            w2: self.w2[k],
            e_q: self.e_q[k],
            e_w: self.e_w[k],
            x2: self.x2[k],
            v2: self.v2[k],
            x_max: self.x_max[k],
            reward: self.reward[k],
        }
    }

    /// Stores eight envs' measures from `first` on (the room is whole groups).
    #[inline(always)]
    fn put(&mut self, first: usize, m: [&Lanes<LANES>; 8]) {
        let rows = [
            &mut self.q2,
            &mut self.w2,
            &mut self.e_q,
            &mut self.e_w,
            &mut self.x2,
            &mut self.v2,
            &mut self.x_max,
            &mut self.reward,
        ];
        for (row, lanes) in rows.into_iter().zip(m) {
            row[first..first + LANES].copy_from_slice(&lanes.0);
        }
    }
}

/// The measures of state `y` for the target signs `s` (one per link), reached by an
/// action of squared norm `a2`, rewarded with weights `w`.
#[inline(always)]
pub fn measure<G: Geometry>(
    lay: Layout<G>,
    y: &[f64],
    s: &[f64],
    w: &RewardWeights,
    a2: f64,
) -> StateMeasure {
    let (mut q2, mut w2, mut e_q, mut e_w) = (0.0, 0.0, 0.0, 0.0);
    for (i, &si) in s.iter().enumerate() {
        let dq = (lay.load_q(y, i) - G::down_unit() * si).norm_squared();
        let dw = lay.load_w(y, i).norm_squared();
        q2 += dq;
        w2 += dw;
        e_q += dq.sqrt();
        e_w += dw.sqrt();
    }
    let x = &y[lay.x()..lay.x() + G::Cart::DIM];
    let x2 = lay.load_x(y).norm_squared();
    let v2 = lay.load_xdot(y).norm_squared();
    StateMeasure {
        q2,
        w2,
        e_q,
        e_w,
        x2,
        v2,
        x_max: x.iter().fold(0.0, |m: f64, v| m.max(v.abs())),
        reward: reward(w, q2, w2, x2, v2, a2),
    }
}

/// [`measure`] of every lane of the lane group `y` (component-major, any lane width
/// and number type) into `out` from env `first` on, eight lanes at a time, widened to
/// f64 as they are read (`a2` holds every env's squared action, with [`room`]).
#[inline(always)]
pub fn measure_group<G, const L: usize, T: LaneReal>(
    lay: Layout<G>,
    y: &[Lanes<L, T>],
    task: &MeasureTask,
    out: &mut Measures,
    first: usize,
) where
    G: LaneGeometry<LANES> + Geometry,
{
    let y = &y[..lay.dim()];
    for at in (0..L).step_by(LANES) {
        let component = |j: usize| {
            let mut v = Lanes::<LANES>::zero();
            for k in 0..LANES.min(L - at) {
                v.0[k] = y[j].0[at + k].to_f64();
            }
            v
        };
        measure_f64x8::<G>(lay, component, task, out, first + at);
    }
}

/// [`measure`] of eight f64 lanes (`component(j)` is component j) into `out` from env
/// `first` on.
#[inline(always)]
fn measure_f64x8<G: LaneGeometry<LANES> + Geometry>(
    lay: Layout<G>,
    component: impl Fn(usize) -> Lanes<LANES>,
    task: &MeasureTask,
    out: &mut Measures,
    first: usize,
) {
    let s = &task.target[..];
    let zero = Lanes::<LANES>::zero();
    let (mut q2, mut w2, mut e_q, mut e_w) = (zero, zero, zero, zero);
    for (i, &si) in s.iter().enumerate() {
        let q = G::LinkL::load_with(lay.q(i), &component);
        let dq = (q - G::lanes_down_unit() * Lanes::splat(si)).norm_squared();
        let dw = G::SpinL::load_with(lay.w(i), &component).norm_squared();
        q2 = q2 + dq;
        w2 = w2 + dw;
        e_q = e_q + dq.sqrt();
        e_w = e_w + dw.sqrt();
    }
    let x2 = G::CartL::load_with(lay.x(), &component).norm_squared();
    let v2 = G::CartL::load_with(lay.xdot(), &component).norm_squared();
    // Equal to the scalar fold but perhaps for the sign of a zero (never compared).
    let mut x_max = zero;
    for c in 0..G::CartL::DIM {
        x_max = x_max.max(component(lay.x() + c).abs());
    }
    // Lane by lane with the scalar function: LLVM vectorises the loop, bits unchanged.
    let a2 = &task.a2[first..first + LANES];
    let mut rewards = zero;
    for k in 0..LANES {
        rewards.0[k] = reward(&task.weights, q2.0[k], w2.0[k], x2.0[k], v2.0[k], a2[k]);
    }
    out.put(first, [&q2, &w2, &e_q, &e_w, &x2, &v2, &x_max, &rewards]);
}

/// What measuring reads besides the state.
#[derive(Debug, Clone)]
pub struct MeasureTask {
    /// The target signs, one per link.
    pub target: Vec<f64>,
    /// The reward's weights.
    pub weights: RewardWeights,
    /// Each env's squared applied action, with [`room`].
    pub a2: Vec<f64>,
}

/// The task's hook on the lanes: measures every stepped group (see
/// [`crate::lanes::ChunkLanes::step`]) into `out`.
#[derive(Debug, Clone)]
pub struct MeasureInto {
    /// Target, reward weights and actions.
    pub task: MeasureTask,
    /// The measures of every env of the step (those of failed envs are garbage).
    pub out: Measures,
}

impl MeasureInto {
    /// Room for `num_envs` envs measured against `target` with `weights` (actions zero).
    pub fn new(target: &[f64], weights: RewardWeights, num_envs: usize) -> Self {
        Self {
            task: MeasureTask {
                target: target.to_vec(),
                weights,
                a2: vec![0.0; room(num_envs)],
            },
            out: Measures::new(num_envs),
        }
    }
}

impl<G: LaneGeometry<LANES> + Geometry, const L: usize, T: LaneReal> AfterStep<G, L, T>
    for MeasureInto
{
    #[inline(always)]
    fn group(&mut self, lay: Layout<G>, y: &[Lanes<L, T>], first: usize, _filled: usize) {
        measure_group(lay, y, &self.task, &mut self.out, first);
    }
}
