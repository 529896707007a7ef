//! What the task reads of a state (distances to the target equilibrium, the cart's
//! offset and speed, and the reward they give with the squared action), computed one
//! state at a time or for a whole lane group at once right after its step (the
//! lanes' [`AfterStep`] hook), with the same operations in the same order, so both
//! give the same bits. Lanes of any width and number type are measured eight at a
//! time in f64 (f32 lanes widened exactly as they are read), as the scalar code
//! measures the f64 state.

// Index loops on purpose: they must inline into the dispatched kernels.
#![allow(clippy::needless_range_loop)]

use super::config::{RewardKind, RewardWeights, TaskConfig};
use crate::geometry::{Geometry, Layout, Vector};
use crate::lanes::exp;
use crate::lanes::{room, AfterStep, LANES};
use crate::lanes::{LaneGeometry, LaneVector};
use crate::lanes::{LaneReal, Lanes};

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
    /// The reward of a step that reached this state (`step_reward`).
    pub reward: f64,
}

/// What a step's reward reads besides the measures of the state it reached.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RewardSpec {
    /// Which reward.
    pub kind: RewardKind,
    /// The quadratic cost's weights ([`RewardKind::Exp`]).
    pub weights: RewardWeights,
    /// `1 / e_q` and `1 / e_w` of the success tolerances ([`RewardKind::Tolerance`]).
    pub inv_tolerance: [f64; 2],
    /// `1 / track_limit^2`.
    pub inv_track2: f64,
    /// `1 / (4 n)`: `q2` is at most `4 n`.
    pub inv_4n: f64,
}

impl RewardSpec {
    /// The reward of `task` for a chain of `n` links.
    pub fn of(task: &TaskConfig, n: usize) -> Self {
        Self {
            kind: task.reward_kind,
            weights: task.reward,
            inv_tolerance: [1.0 / task.success.e_q, 1.0 / task.success.e_w],
            inv_track2: 1.0 / (task.track_limit * task.track_limit),
            inv_4n: 1.0 / (4.0 * n.max(1) as f64),
        }
    }

    /// The quadratic reward with these weights (the other fields unused).
    pub fn exp(weights: RewardWeights) -> Self {
        Self {
            kind: RewardKind::Exp,
            weights,
            inv_tolerance: [1.0; 2],
            inv_track2: 0.0,
            inv_4n: 1.0,
        }
    }
}

/// The reward of a step that reached a state with these measures by an action of
/// squared norm `a2`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn step_reward(
    spec: &RewardSpec,
    q2: f64,
    w2: f64,
    e_q: f64,
    e_w: f64,
    x2: f64,
    v2: f64,
    a2: f64,
) -> f64 {
    match spec.kind {
        RewardKind::Exp => reward(&spec.weights, q2, w2, x2, v2, a2),
        RewardKind::Tolerance => tolerance_reward(spec, q2, e_q, e_w, x2, a2),
    }
}

/// The bounded reward `(upright + near) / 2 * centred * gentle`, each factor in
/// [0, 1]: `upright = 1 - q2 / (4 n)` (1 at the target's directions, 0 with every
/// link opposite: a slope all the way from the start of a large motion),
/// `near = 10^(-(z_q^2 + z_w^2) / 4)` with `z = e / tolerance` (1 at rest on the target,
/// a tenth at twice the tolerance: the precision the success asks for),
/// `centred = (1 + 10^(-x2 / track^2)) / 2` (0.55 at the track's end) and
/// `gentle = 0.8 + 0.2 max(0, 1 - a2)` (a full push costs a fifth).
#[inline(always)]
pub fn tolerance_reward(spec: &RewardSpec, q2: f64, e_q: f64, e_w: f64, x2: f64, a2: f64) -> f64 {
    const LN10: f64 = std::f64::consts::LN_10;
    let upright = (1.0 - q2 * spec.inv_4n).max(0.0);
    let (z_q, z_w) = (e_q * spec.inv_tolerance[0], e_w * spec.inv_tolerance[1]);
    let near = exp(-0.25 * LN10 * (z_q * z_q + z_w * z_w));
    let centred = 0.5 * (1.0 + exp(-LN10 * x2 * spec.inv_track2));
    let gentle = 0.8 + 0.2 * (1.0 - a2).max(0.0);
    0.5 * (upright + near) * centred * gentle
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
/// action of squared norm `a2`, rewarded as `w` says.
#[inline(always)]
pub fn measure<G: Geometry>(
    lay: Layout<G>,
    y: &[f64],
    s: &[f64],
    w: &RewardSpec,
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
        reward: step_reward(w, q2, w2, e_q, e_w, x2, v2, a2),
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
    let zero = Lanes::<LANES>::zero();
    // Two copies of the link loop, each without a branch inside: one target for all
    // envs (a splat), or each env's own (goal-conditioned; the same values loaded).
    let [q2, w2, e_q, e_w] = match &task.env_targets {
        None => link_errors(lay, &component, |i| Lanes::splat(task.target[i])),
        Some(t) => link_errors(lay, &component, |i| {
            let mut v = zero;
            v.0.copy_from_slice(&t[i * task.room + first..][..LANES]);
            v
        }),
    };
    let x2 = G::CartL::load_with(lay.x(), &component).norm_squared();
    let v2 = G::CartL::load_with(lay.xdot(), &component).norm_squared();
    // Equal to the scalar fold but perhaps for the sign of a zero (never compared).
    let mut x_max = zero;
    for c in 0..G::CartL::DIM {
        x_max = x_max.max(component(lay.x() + c).abs());
    }
    // Lane by lane with the scalar functions: LLVM vectorises each loop (the choice of
    // reward outside them), bits unchanged.
    let a2 = &task.a2[first..first + LANES];
    let spec = &task.reward;
    let mut rewards = zero;
    match spec.kind {
        RewardKind::Exp => {
            for k in 0..LANES {
                rewards.0[k] = reward(&spec.weights, q2.0[k], w2.0[k], x2.0[k], v2.0[k], a2[k]);
            }
        }
        RewardKind::Tolerance => {
            for k in 0..LANES {
                rewards.0[k] = tolerance_reward(spec, q2.0[k], e_q.0[k], e_w.0[k], x2.0[k], a2[k]);
            }
        }
    }
    out.put(first, [&q2, &w2, &e_q, &e_w, &x2, &v2, &x_max, &rewards]);
}

/// `[q2, w2, e_q, e_w]` of eight lanes summed over the links, `target(i)` the lanes'
/// target sign of link `i`.
#[inline(always)]
fn link_errors<G: LaneGeometry<LANES> + Geometry>(
    lay: Layout<G>,
    component: &impl Fn(usize) -> Lanes<LANES>,
    target: impl Fn(usize) -> Lanes<LANES>,
) -> [Lanes<LANES>; 4] {
    let zero = Lanes::<LANES>::zero();
    let (mut q2, mut w2, mut e_q, mut e_w) = (zero, zero, zero, zero);
    for i in 0..lay.n {
        let q = G::LinkL::load_with(lay.q(i), component);
        let dq = (q - G::lanes_down_unit() * target(i)).norm_squared();
        let dw = G::SpinL::load_with(lay.w(i), component).norm_squared();
        q2 = q2 + dq;
        w2 = w2 + dw;
        e_q = e_q + dq.sqrt();
        e_w = e_w + dw.sqrt();
    }
    [q2, w2, e_q, e_w]
}

/// What measuring reads besides the state.
#[derive(Debug, Clone)]
pub struct MeasureTask {
    /// The target signs, one per link.
    pub target: Vec<f64>,
    /// The reward.
    pub reward: RewardSpec,
    /// Each env's squared applied action, with [`room`].
    pub a2: Vec<f64>,
    /// Goal-conditioned tasks: each env's target signs, link-major (`room` per link),
    /// written before the step; `None`: every env has `target`.
    pub env_targets: Option<Vec<f64>>,
    /// Envs per link in `env_targets` (the [`room`] of the chunk).
    pub room: usize,
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
    /// Room for `num_envs` envs measured against `target` and rewarded by `reward`
    /// (actions zero); `per_env_targets`: each env's target is written before a step.
    pub fn new(target: &[f64], reward: RewardSpec, num_envs: usize, per_env_targets: bool) -> Self {
        let room = room(num_envs);
        Self {
            task: MeasureTask {
                target: target.to_vec(),
                reward,
                a2: vec![0.0; room],
                env_targets: per_env_targets.then(|| vec![0.0; room * target.len()]),
                room,
            },
            out: Measures::new(num_envs),
        }
    }

    /// Sets env `k`'s target signs (goal-conditioned tasks; else does nothing).
    #[inline(always)]
    pub fn set_target(&mut self, k: usize, signs: &[f64]) {
        if let Some(t) = self.task.env_targets.as_mut() {
            for (i, &s) in signs.iter().enumerate() {
                t[i * self.task.room + k] = s;
            }
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
