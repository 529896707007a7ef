//! One control period of a range of envs: named per-env views of the batch's arrays,
//! the reset of one env and the step of one env (actuation, physics, scoring,
//! sensing). The engine splits the envs into fixed chunks of
//! [`crate::engine::CHUNK`] envs, each with its own [`Worker`]; chunks run in parallel,
//! and no env reads another's data, so the split never changes a result.
//!
//! With a lane kernel (rk4) a chunk runs in three phases instead of env by env:
//! every env's autoreset or actuation, then one lane step of the envs that step, then
//! every stepped env's scoring, same-step reset and observation. Envs are independent,
//! so the phase order gives each env exactly the bits of the env-by-env order.

use super::config::{AutoresetMode, TaskConfig};
use super::measure::{measure, MeasureInto, RewardSpec, StateMeasure};
use super::outputs::{event, Real, DIAGNOSTICS};
use super::reality::{EnvParams, ParamRow, RealityGap, RigRow};
use super::start::perturb;
use crate::engine::{ChunkLanePath, EnvRange, Worker};
use crate::geometry::{Geometry, Layout, Vector};
use crate::integrate::StepStatus;
use crate::lanes::StepPlan;
use crate::model::Chain;
use crate::params::ChainParams;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// Per-env bookkeeping besides the state, read and written every step (kept apart
/// from the env's start-state generator, ten times its size and needed only at
/// resets, so that a step's pass over the envs reads 16 bytes per env, not 336).
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Slot {
    pub steps: u64,
    /// Consecutive steps up to now within the success tolerances.
    pub held: u32,
    /// Consecutive steps of this episode within `fall_limit` so far, counted up to
    /// [`TaskConfig::fall_arm_steps`], where a fall is armed and the count stays.
    pub caught: u16,
    /// Goal-conditioned tasks: the episode's (start, target) pair.
    pub goal: u16,
    /// The episode has ended and the env has not been reset since.
    pub ended: bool,
    /// The episode's control delay (control periods), set at its reset.
    pub delay: u32,
}

/// Numbers per env of each per-env array (0 for a feature that is off).
#[derive(Debug, Clone, Copy)]
pub(super) struct Widths {
    /// State length.
    pub state: usize,
    /// Observation length: the state, then the target's signs if observed.
    pub obs: usize,
    /// Action length.
    pub force: usize,
    /// Links stored per env in [`EnvParams`] (0: parameters shared).
    pub param_links: usize,
    /// 1 when each env stores its own scalar parameters and parameter stream.
    pub param_scalars: usize,
    /// Joint dampings stored per env (links, when rig effects are drawn; else 0).
    pub rig_links: usize,
    /// 1 when each env stores its own cart frictions.
    pub rig_scalars: usize,
    /// Delayed actions per env (the longest delay times `force`).
    pub queue: usize,
    /// Sensed observation per env (`state` when noise or an encoder is on).
    pub noisy: usize,
    /// Last applied force per env (`force` with a rate limit), then the episode's
    /// limit where each episode draws one.
    pub last_force: usize,
    /// 1 when each env has an observation-noise stream.
    pub noise_rng: usize,
    /// 1 when each env has a force-noise stream.
    pub force_rng: usize,
    /// Some per-env extra above is non-zero.
    pub any_gap: bool,
}

impl Widths {
    pub fn new<G: Geometry>(chain: &Chain<G>, task: &TaskConfig) -> Self {
        let reality = &task.reality;
        let (d, f) = (chain.state_dim(), chain.force_dim());
        let randomized = !reality.randomize.is_off();
        let rig_drawn = reality.randomize.draws_rig();
        let noise = reality.has_obs_noise();
        let queue = reality.max_action_delay() * f;
        let last_force = if reality.draws_rate_limit() {
            f + 1
        } else if reality.has_rate_limit() {
            f
        } else {
            0
        };
        let force_noise = reality.has_force_noise();
        let sensed = noise || task.sensors.is_on();
        Self {
            state: d,
            obs: task.obs_dim(d),
            force: f,
            param_links: if randomized { chain.n_links() } else { 0 },
            param_scalars: randomized as usize,
            rig_links: if rig_drawn { chain.n_links() } else { 0 },
            rig_scalars: rig_drawn as usize,
            queue,
            noisy: if sensed { d } else { 0 },
            last_force,
            noise_rng: noise as usize,
            force_rng: force_noise as usize,
            any_gap: randomized || sensed || queue > 0 || last_force > 0 || force_noise,
        }
    }
}

/// The evolving per-env data of a batch, each a contiguous array over the envs
/// (empty for a feature that is off).
#[derive(Debug, Clone)]
pub(super) struct EnvData {
    pub states: Vec<f64>,
    pub slots: Vec<Slot>,
    /// Stream 0 of each env's generator: start states.
    pub start_rngs: Vec<ChaCha8Rng>,
    pub params: EnvParams,
    /// Parameter stream of each env's generator (randomisation on).
    pub param_rngs: Vec<ChaCha8Rng>,
    /// Observation-noise stream of each env's generator (noise on).
    pub noise_rngs: Vec<ChaCha8Rng>,
    /// The last observation each env emitted (noise or an encoder on): the encoders'
    /// previous reading and velocity filter state.
    pub noisy_obs: Vec<f64>,
    /// Actions waiting to be applied, a ring of the episode's delay per env (room for
    /// the longest).
    pub queue: Vec<f64>,
    /// The force applied on the last step (rate limit on).
    pub last_force: Vec<f64>,
    /// Force-noise stream of each env's generator (force noise on).
    pub force_rngs: Vec<ChaCha8Rng>,
}

impl EnvData {
    pub fn view(&mut self) -> DataRange<'_> {
        DataRange {
            states: &mut self.states,
            slots: &mut self.slots,
            start_rngs: &mut self.start_rngs,
            cart_mass: &mut self.params.cart_mass,
            link_masses: &mut self.params.link_masses,
            link_lengths: &mut self.params.link_lengths,
            gravity: &mut self.params.gravity,
            joint_damping: &mut self.params.joint_damping,
            cart_viscous_friction: &mut self.params.cart_viscous_friction,
            cart_coulomb_friction: &mut self.params.cart_coulomb_friction,
            param_rngs: &mut self.param_rngs,
            noise_rngs: &mut self.noise_rngs,
            noisy_obs: &mut self.noisy_obs,
            queue: &mut self.queue,
            last_force: &mut self.last_force,
            force_rngs: &mut self.force_rngs,
        }
    }
}

/// Splits `s` after `at` envs of `width` numbers each (an empty array splits into
/// two empty halves).
#[inline(always)]
fn cut<S>(s: &mut [S], at: usize, width: usize) -> (&mut [S], &mut [S]) {
    let at = (at * width).min(s.len());
    s.split_at_mut(at)
}

/// Env `k`'s row of `width` numbers.
#[inline(always)]
fn row<S>(s: &mut [S], k: usize, width: usize) -> &mut [S] {
    &mut s[k * width..(k + 1) * width]
}

/// The evolving data of a contiguous range of envs.
pub(super) struct DataRange<'a> {
    states: &'a mut [f64],
    slots: &'a mut [Slot],
    start_rngs: &'a mut [ChaCha8Rng],
    cart_mass: &'a mut [f64],
    link_masses: &'a mut [f64],
    link_lengths: &'a mut [f64],
    gravity: &'a mut [f64],
    joint_damping: &'a mut [f64],
    cart_viscous_friction: &'a mut [f64],
    cart_coulomb_friction: &'a mut [f64],
    param_rngs: &'a mut [ChaCha8Rng],
    noise_rngs: &'a mut [ChaCha8Rng],
    noisy_obs: &'a mut [f64],
    queue: &'a mut [f64],
    last_force: &'a mut [f64],
    force_rngs: &'a mut [ChaCha8Rng],
}

impl<'a> DataRange<'a> {
    fn split_at(self, at: usize, w: &Widths) -> (Self, Self) {
        let (states, states2) = cut(self.states, at, w.state);
        let (slots, slots2) = cut(self.slots, at, 1);
        let (start_rngs, start_rngs2) = cut(self.start_rngs, at, 1);
        let (cart_mass, cart_mass2) = cut(self.cart_mass, at, w.param_scalars);
        let (link_masses, link_masses2) = cut(self.link_masses, at, w.param_links);
        let (link_lengths, link_lengths2) = cut(self.link_lengths, at, w.param_links);
        let (gravity, gravity2) = cut(self.gravity, at, w.param_scalars);
        let (joint_damping, joint_damping2) = cut(self.joint_damping, at, w.rig_links);
        let (viscous, viscous2) = cut(self.cart_viscous_friction, at, w.rig_scalars);
        let (coulomb, coulomb2) = cut(self.cart_coulomb_friction, at, w.rig_scalars);
        let (param_rngs, param_rngs2) = cut(self.param_rngs, at, w.param_scalars);
        let (noise_rngs, noise_rngs2) = cut(self.noise_rngs, at, w.noise_rng);
        let (noisy_obs, noisy_obs2) = cut(self.noisy_obs, at, w.noisy);
        let (queue, queue2) = cut(self.queue, at, w.queue);
        let (last_force, last_force2) = cut(self.last_force, at, w.last_force);
        let (force_rngs, force_rngs2) = cut(self.force_rngs, at, w.force_rng);
        (
            Self {
                states,
                slots,
                start_rngs,
                cart_mass,
                link_masses,
                link_lengths,
                gravity,
                joint_damping,
                cart_viscous_friction: viscous,
                cart_coulomb_friction: coulomb,
                param_rngs,
                noise_rngs,
                noisy_obs,
                queue,
                last_force,
                force_rngs,
            },
            DataRange {
                states: states2,
                slots: slots2,
                start_rngs: start_rngs2,
                cart_mass: cart_mass2,
                link_masses: link_masses2,
                link_lengths: link_lengths2,
                gravity: gravity2,
                joint_damping: joint_damping2,
                cart_viscous_friction: viscous2,
                cart_coulomb_friction: coulomb2,
                param_rngs: param_rngs2,
                noise_rngs: noise_rngs2,
                noisy_obs: noisy_obs2,
                queue: queue2,
                last_force: last_force2,
                force_rngs: force_rngs2,
            },
        )
    }

    fn len(&self) -> usize {
        self.slots.len()
    }

    /// The named view of env `k` of the range.
    #[inline(always)]
    pub fn env(&mut self, k: usize, w: &Widths) -> EnvMut<'_> {
        if !w.any_gap {
            // The common case: no per-env extras to slice.
            return EnvMut {
                y: row(self.states, k, w.state),
                slot: &mut self.slots[k],
                start_rng: &mut self.start_rngs[k],
                params: None,
                param_rng: None,
                noise_rng: None,
                noisy_obs: &mut [],
                queue: &mut [],
                last_force: &mut [],
                force_rng: None,
            };
        }
        let params = (w.param_scalars == 1).then(|| ParamRow {
            cart_mass: &mut self.cart_mass[k],
            link_masses: row(self.link_masses, k, w.param_links),
            link_lengths: row(self.link_lengths, k, w.param_links),
            gravity: &mut self.gravity[k],
            rig: RigRow {
                joint_damping: row(self.joint_damping, k, w.rig_links),
                cart_viscous_friction: row(self.cart_viscous_friction, k, w.rig_scalars),
                cart_coulomb_friction: row(self.cart_coulomb_friction, k, w.rig_scalars),
            },
        });
        EnvMut {
            y: row(self.states, k, w.state),
            slot: &mut self.slots[k],
            start_rng: &mut self.start_rngs[k],
            params,
            param_rng: self.param_rngs.get_mut(k),
            noise_rng: self.noise_rngs.get_mut(k),
            noisy_obs: row(self.noisy_obs, k, w.noisy),
            queue: row(self.queue, k, w.queue),
            last_force: row(self.last_force, k, w.last_force),
            force_rng: self.force_rngs.get_mut(k),
        }
    }
}

/// Everything that evolves in one env.
pub(super) struct EnvMut<'a> {
    pub y: &'a mut [f64],
    pub slot: &'a mut Slot,
    /// Stream 0 of the env's generator: start states.
    pub start_rng: &'a mut ChaCha8Rng,
    /// The env's own parameters (randomisation on), else the batch's shared set.
    pub params: Option<ParamRow<'a>>,
    pub param_rng: Option<&'a mut ChaCha8Rng>,
    pub noise_rng: Option<&'a mut ChaCha8Rng>,
    pub noisy_obs: &'a mut [f64],
    pub queue: &'a mut [f64],
    pub last_force: &'a mut [f64],
    pub force_rng: Option<&'a mut ChaCha8Rng>,
}

/// The caller's actions and the output arrays of a contiguous range of envs.
pub(super) struct OutRange<'a, T: Real, A: Real> {
    pub actions: &'a [A],
    pub obs: &'a mut [T],
    pub rewards: &'a mut [f64],
    pub terminated: &'a mut [bool],
    pub truncated: &'a mut [bool],
    pub events: &'a mut [u8],
    pub errors: &'a mut [f64],
    pub finals: &'a mut [f64],
    pub diag: &'a mut [f64],
}

impl<'a, T: Real, A: Real> OutRange<'a, T, A> {
    fn split_at(self, at: usize, w: &Widths) -> (Self, Self) {
        let (actions, actions2) = self
            .actions
            .split_at((at * w.force).min(self.actions.len()));
        let (obs, obs2) = cut(self.obs, at, w.obs);
        let (rewards, rewards2) = cut(self.rewards, at, 1);
        let (terminated, terminated2) = cut(self.terminated, at, 1);
        let (truncated, truncated2) = cut(self.truncated, at, 1);
        let (events, events2) = cut(self.events, at, 1);
        let (errors, errors2) = cut(self.errors, at, 2);
        let (finals, finals2) = cut(self.finals, at, w.obs);
        let (diag, diag2) = cut(self.diag, at, DIAGNOSTICS.len());
        (
            Self {
                actions,
                obs,
                rewards,
                terminated,
                truncated,
                events,
                errors,
                finals,
                diag,
            },
            OutRange {
                actions: actions2,
                obs: obs2,
                rewards: rewards2,
                terminated: terminated2,
                truncated: truncated2,
                events: events2,
                errors: errors2,
                finals: finals2,
                diag: diag2,
            },
        )
    }

    #[inline(always)]
    fn env(&mut self, k: usize, w: &Widths) -> EnvOut<'_, T, A> {
        let nd = DIAGNOSTICS.len();
        EnvOut {
            action: &self.actions[k * w.force..(k + 1) * w.force],
            obs: row(self.obs, k, w.obs),
            reward: &mut self.rewards[k],
            terminated: &mut self.terminated[k],
            truncated: &mut self.truncated[k],
            event: &mut self.events[k],
            errors: row(self.errors, k, 2),
            finals: row(self.finals, k, w.obs),
            diag: row(self.diag, k, nd),
        }
    }
}

/// One env's action and outputs.
pub(super) struct EnvOut<'a, T: Real, A: Real> {
    action: &'a [A],
    obs: &'a mut [T],
    reward: &'a mut f64,
    terminated: &'a mut bool,
    truncated: &'a mut bool,
    event: &'a mut u8,
    errors: &'a mut [f64],
    finals: &'a mut [f64],
    diag: &'a mut [f64],
}

/// Everything a step reads (shared by all chunks).
pub(super) struct Ctx<'a, G: Geometry> {
    /// The true system shared by all envs when parameters are not per env.
    pub chain: &'a Chain<G>,
    /// The true parameters randomisation draws around.
    pub truth: &'a ChainParams,
    pub task: &'a TaskConfig,
    /// The state episodes start from before noise; goal-conditioned, one per pair.
    pub base: &'a [f64],
    /// The reward of the task on this chain.
    pub reward: RewardSpec,
    /// [`TaskConfig::hold_steps`].
    pub hold_steps: u32,
    /// [`TaskConfig::fall_arm_steps`].
    pub fall_arm_steps: u16,
    pub mode: AutoresetMode,
    pub diagnostics: bool,
    pub widths: Widths,
    /// Per-env parameters changed outside a step (reset, restore, new lane path):
    /// the lane paths load every env's before stepping.
    pub reload_params: bool,
}

/// One step's per-env data and outputs, split by the engine at chunk boundaries.
pub(super) struct Pass<'a, T: Real, A: Real> {
    data: DataRange<'a>,
    out: OutRange<'a, T, A>,
    widths: Widths,
}

impl<'a, T: Real, A: Real> Pass<'a, T, A> {
    /// The pass over every env of a batch.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        data: DataRange<'a>,
        actions: &'a [A],
        out: super::outputs::StepOutputs<'a, T>,
        events: &'a mut [u8],
        errors: &'a mut [f64],
        finals: &'a mut [f64],
        diag: &'a mut [f64],
        widths: Widths,
    ) -> Self {
        let out = OutRange {
            actions,
            obs: out.obs,
            rewards: out.rewards,
            terminated: out.terminated,
            truncated: out.truncated,
            events,
            errors,
            finals,
            diag,
        };
        Self { data, out, widths }
    }
}

impl<T: Real, A: Real> EnvRange for Pass<'_, T, A> {
    fn num_envs(&self) -> usize {
        self.data.len()
    }
    fn split_at(self, at: usize) -> (Self, Self) {
        let w = self.widths;
        let (data_a, data_b) = self.data.split_at(at, &w);
        let (out_a, out_b) = self.out.split_at(at, &w);
        (
            Self {
                data: data_a,
                out: out_a,
                widths: w,
            },
            Self {
                data: data_b,
                out: out_b,
                widths: w,
            },
        )
    }
}

/// Steps the envs of one chunk on this thread: env by env, or in phases around one
/// lane step when the worker has a lane path.
pub(super) fn run_chunk<G: Geometry, T: Real, A: Real>(
    ctx: &Ctx<'_, G>,
    pass: Pass<'_, T, A>,
    worker: &mut Worker<G, MeasureInto>,
) {
    let Pass {
        mut data, mut out, ..
    } = pass;
    if worker.lanes.is_some() {
        run_chunk_lanes(ctx, data, out, worker);
        return;
    }
    for k in 0..data.len() {
        step_env(
            ctx,
            worker,
            data.env(k, &ctx.widths),
            out.env(k, &ctx.widths),
        );
    }
}

/// [`run_chunk`] through the worker's lane path: (a) per env, autoreset or actuate;
/// (b) one lane step of the envs that step; (c) per stepped env, score, diagnostics,
/// same-step reset and observation. A failed env keeps its last good state (the
/// lane path writes back only successful lanes) and its lane neighbours are untouched.
/// Kept out of line: one call per chunk, and the env-by-env loop stays as compact as
/// it was without it.
#[inline(never)]
fn run_chunk_lanes<G: Geometry, T: Real, A: Real>(
    ctx: &Ctx<'_, G>,
    mut data: DataRange<'_>,
    mut out: OutRange<'_, T, A>,
    worker: &mut Worker<G, MeasureInto>,
) {
    let Worker {
        chain: scratch,
        lanes: Some(l),
        ..
    } = worker
    else {
        return;
    };
    let (w, task) = (&ctx.widths, ctx.task);
    let (num_envs, f) = (data.len(), w.force);
    if ctx.reload_params {
        for k in 0..num_envs {
            load_lane_params(scratch, l, k, &data.env(k, w).params);
        }
    }
    let goals = task.transitions.is_some();
    for k in 0..num_envs {
        let mut e = data.env(k, w);
        let o = out.env(k, w);
        l.stepped[k] = !e.slot.ended;
        if e.slot.ended {
            autoreset_step(ctx, scratch, e, o);
            load_lane_params(scratch, l, k, &data.env(k, w).params);
            continue;
        }
        l.hook.task.a2[k] = actuate(task, &mut e, o.action, &mut l.forces[k * f..(k + 1) * f]);
        if goals {
            l.hook.set_target(k, task.target_of(e.slot.goal));
        }
    }
    let plan = StepPlan {
        dt: task.dt,
        substeps: task.step_options.substeps,
        guard: &task.guard,
    };
    l.step(&mut data.states[..num_envs * w.state], num_envs, f, plan);
    // Without noise, encoders or an observed goal, observations are the state rows.
    let rows_are_obs = w.noisy == 0 && w.obs == w.state;
    for k in 0..num_envs {
        if !l.stepped[k] {
            continue;
        }
        let mut e = data.env(k, w);
        // The env's own chain is only read by the diagnostics: load it only for them.
        let chain = if ctx.diagnostics {
            env_chain(ctx, scratch, &e.params)
        } else {
            ctx.chain
        };
        let status = l.status[k];
        // A failed env kept its old state, which its lane did not measure.
        let m = if status.is_failure() {
            measure(
                ctx.chain.layout(),
                e.y,
                task.target_of(e.slot.goal),
                &ctx.reward,
                l.hook.task.a2[k],
            )
        } else {
            l.hook.out.get(k)
        };
        let mut o = out.env(k, w);
        let reset = finish_step(ctx, chain, &mut e, &mut o, status, &m);
        if !rows_are_obs {
            emit_obs(task, ctx.chain.layout(), &mut e, o.obs);
        }
        if reset {
            load_lane_params(scratch, l, k, &data.env(k, w).params);
        }
    }
    if rows_are_obs {
        // Every env's observation is its state: one pass over the chunk's rows.
        write_obs(
            &data.states[..num_envs * w.state],
            &mut out.obs[..num_envs * w.state],
        );
    }
}

/// Loads env `k`'s own parameters (if it has any) into its lane, computed through the
/// scratch chain exactly as the per-env path computes them.
fn load_lane_params<G: Geometry>(
    scratch: &mut Chain<G>,
    lanes: &mut ChunkLanePath<MeasureInto>,
    k: usize,
    params: &Option<ParamRow<'_>>,
) {
    if let Some(p) = params {
        scratch.set_params_unchecked(*p.cart_mass, p.link_masses, p.link_lengths, *p.gravity);
        // Same link count by construction: the batch built the lanes from this chain.
        let loaded = lanes.set_env_params(k, scratch.params());
        debug_assert!(loaded.is_ok(), "{loaded:?}");
    }
}

/// The chain env `e` steps with: the shared true chain, or the worker's scratch chain
/// loaded with the env's own parameters.
#[inline(always)]
fn env_chain<'c, G: Geometry>(
    ctx: &'c Ctx<'_, G>,
    scratch: &'c mut Chain<G>,
    params: &Option<ParamRow<'_>>,
) -> &'c Chain<G> {
    match params {
        None => ctx.chain,
        Some(p) => {
            scratch.set_params_unchecked(*p.cart_mass, p.link_masses, p.link_lengths, *p.gravity);
            if p.rig.is_drawn() {
                scratch.set_rig_unchecked(
                    p.rig.joint_damping,
                    p.rig.cart_viscous_friction[0],
                    p.rig.cart_coulomb_friction[0],
                );
            }
            scratch
        }
    }
}

/// Starts a new episode in env `e`: the start state (stream 0, as always), new
/// parameters (randomisation on), its control delay (drawn from the start stream
/// after the start state when the delay is a range), an empty delay line and zero
/// last force.
pub(super) fn reset_env<G: Geometry>(ctx: &Ctx<'_, G>, e: &mut EnvMut<'_>) {
    let base = match &ctx.task.transitions {
        None => ctx.base,
        Some(t) => {
            // The pair first, from the start stream: a fixed task draws nothing here.
            let goal = e.start_rng.random_range(0..t.len());
            e.slot.goal = goal as u16;
            let d = ctx.widths.state;
            &ctx.base[goal * d..(goal + 1) * d]
        }
    };
    perturb(
        ctx.chain.layout(),
        base,
        ctx.task.start_noise,
        e.start_rng,
        e.y,
    );
    e.slot.delay = ctx.task.reality.draw_action_delay(e.start_rng) as u32;
    e.slot.steps = 0;
    e.slot.held = 0;
    e.slot.caught = 0;
    e.slot.ended = false;
    if let (Some(p), Some(rng)) = (e.params.as_mut(), e.param_rng.as_deref_mut()) {
        p.sample(&ctx.task.reality.randomize, ctx.truth, ctx.chain.rig(), rng);
    }
    e.queue.fill(0.0);
    e.last_force.fill(0.0);
    if ctx.task.reality.draws_rate_limit() {
        // After the delay's draw, so that a fixed limit leaves the start stream as it was.
        let limit = ctx.task.reality.draw_force_rate_limit(e.start_rng);
        if let Some(slot) = e.last_force.get_mut(ctx.widths.force) {
            *slot = limit;
        }
    }
}

/// `dst = y + sigma * z` per component, `z` standard normal from `rng`.
fn add_noise(reality: &RealityGap, y: &[f64], rng: &mut ChaCha8Rng, dst: &mut [f64]) {
    for (k, (o, &v)) in dst.iter_mut().zip(y).enumerate() {
        let z: f64 = rng.sample(StandardNormal);
        *o = v + reality.noise_scale(k) * z;
    }
}

/// With sensor noise or an encoder on, takes a fresh reading of env `e`'s state into
/// `e.noisy_obs`, the env's current observation (`first`: the first reading of an
/// episode, with no previous count to estimate velocities from); without, does
/// nothing.
pub(super) fn sense<G: Geometry>(
    task: &TaskConfig,
    layout: Layout<G>,
    e: &mut EnvMut<'_>,
    first: bool,
) {
    let reality = &task.reality;
    if !task.sensors.is_on() {
        if let Some(rng) = e.noise_rng.as_deref_mut() {
            add_noise(reality, e.y, rng, e.noisy_obs);
        }
        return;
    }
    let y = &*e.y;
    let mut noise = e.noise_rng.as_deref_mut();
    // The noise of component k, drawn in component order as `add_noise` draws it.
    let seen = |k: usize| match noise.as_deref_mut() {
        None => y[k],
        Some(rng) => {
            let z: f64 = rng.sample(StandardNormal);
            y[k] + reality.noise_scale(k) * z
        }
    };
    task.sensors.read(layout, seen, first, task.dt, e.noisy_obs);
}

/// Writes env `e`'s observation: its state, or a fresh reading of it (noise, encoders),
/// then the target's signs when the task observes them.
pub(super) fn emit_obs<T: Real, G: Geometry>(
    task: &TaskConfig,
    layout: Layout<G>,
    e: &mut EnvMut<'_>,
    obs: &mut [T],
) {
    let d = e.y.len();
    if !e.noisy_obs.is_empty() {
        let first = e.slot.steps == 0;
        sense(task, layout, e, first);
        write_obs(e.noisy_obs, &mut obs[..d]);
    } else {
        write_obs(e.y, &mut obs[..d]);
    }
    write_goal(task, e.slot.goal, &mut obs[d..]);
}

/// The target's signs at the end of an observation (nothing when not observed).
#[inline(always)]
pub(super) fn write_goal<T: Real>(task: &TaskConfig, goal: u16, tail: &mut [T]) {
    if task.goal_observation {
        write_obs(task.target_of(goal), tail);
    }
}

#[inline(always)]
pub(super) fn write_obs<T: Real>(y: &[f64], obs: &mut [T]) {
    for (o, &s) in obs.iter_mut().zip(y) {
        *o = T::from_f64(s);
    }
}

/// Writes the force the actuator applies for `action` into `force` (one number per
/// axis) and returns the squared norm of the applied normalised action (for the
/// reward): clip to `[-1, 1]`, delay by `action_delay` control periods, scale by
/// `max_force` (or, with another actuation, the command's own scale: see
/// [`TaskConfig::command_scale`]; the chain reads the command in that mode's unit), limit the change per period to `force_rate_limit * dt` per axis, and
/// disturb what the actuator delivers by the force noise (after the squared action is
/// taken and after the rate limit's memory, which holds the commanded force).
/// Written in place rather than returned: copying a returned array that was just
/// written number by number stalled the lane path's actuation pass (store forwarding).
#[inline(always)]
fn actuate<A: Real>(task: &TaskConfig, e: &mut EnvMut<'_>, action: &[A], force: &mut [f64]) -> f64 {
    let f = action.len();
    let delay = e.slot.delay;
    // The ring slot of this step holds the action of `delay` steps ago.
    let j = if delay > 0 {
        (e.slot.steps % delay as u64) as usize * f
    } else {
        0
    };
    // One pass per axis, each number used where it is made: reading back an array
    // just written number by number stalled on store forwarding.
    let scale = task.command_scale();
    let mut a = [0.0; 3];
    let mut a2 = 0.0;
    for (k, (x, fk)) in action.iter().zip(force.iter_mut()).enumerate() {
        let mut ak = x.to_f64().clamp(-1.0, 1.0);
        if delay > 0 {
            std::mem::swap(&mut ak, &mut e.queue[j + k]);
        }
        a[k] = ak;
        a2 += ak * ak;
        *fk = ak * scale;
    }
    if !e.last_force.is_empty() {
        // The episode's own limit sits after the last forces where each episode draws one.
        let limit = e
            .last_force
            .get(f)
            .copied()
            .unwrap_or(task.reality.force_rate_limit);
        let max_change = limit * task.dt;
        a2 = 0.0;
        for (k, (fk, last)) in force.iter_mut().zip(e.last_force.iter_mut()).enumerate() {
            *fk = fk.clamp(*last - max_change, *last + max_change);
            *last = *fk;
            let applied = if scale > 0.0 { *fk / scale } else { a[k] };
            a2 += applied * applied;
        }
    }
    if let Some(rng) = e.force_rng.as_deref_mut() {
        let noise = task.reality.force_noise;
        for fk in force.iter_mut() {
            *fk = noise.disturb(*fk, rng);
        }
    }
    a2
}

fn write_diagnostics<G: Geometry>(chain: &Chain<G>, y: &[f64], diag: &mut [f64]) {
    let e = chain.energy(y);
    let r = chain.residuals(y);
    diag.copy_from_slice(&[e.total(), e.kinetic, e.potential, r.unit_length, r.tangency]);
}

/// Next-step autoreset: the step after an episode ended resets the env instead.
fn autoreset_step<G: Geometry, T: Real, A: Real>(
    ctx: &Ctx<'_, G>,
    scratch: &mut Chain<G>,
    mut e: EnvMut<'_>,
    o: EnvOut<'_, T, A>,
) {
    reset_env(ctx, &mut e);
    emit_obs(ctx.task, ctx.chain.layout(), &mut e, o.obs);
    *o.reward = 0.0;
    *o.terminated = false;
    *o.truncated = false;
    *o.event = event::RESET;
    let m = measure(
        ctx.chain.layout(),
        e.y,
        ctx.task.target_of(e.slot.goal),
        &ctx.reward,
        0.0,
    );
    o.errors.copy_from_slice(&[m.e_q, m.e_w]);
    if ctx.diagnostics {
        let chain = env_chain(ctx, scratch, &e.params);
        write_diagnostics(chain, e.y, o.diag);
    }
}

/// Reward, flags, errors and event bits of the state an env step reached, from its
/// measures `m` (which hold the reward).
#[inline(always)]
fn score<G: Geometry>(
    ctx: &Ctx<'_, G>,
    m: &StateMeasure,
    slot: &mut Slot,
    failed: bool,
    o: &mut EnvOut<'_, impl Real, impl Real>,
) -> u8 {
    let steps = slot.steps;
    let task = ctx.task;
    let off_track = !failed && m.x_max > task.track_limit;
    let fell = !failed && !off_track && falls(task.fall_limit, ctx.fall_arm_steps, m.e_q, slot);
    let terminated = failed || off_track || fell;
    let truncated = steps >= task.max_episode_steps;
    *o.reward = if failed { 0.0 } else { m.reward };
    *o.terminated = terminated;
    *o.truncated = truncated;
    o.errors.copy_from_slice(&[m.e_q, m.e_w]);
    let within = m.e_q <= task.success.e_q && m.e_w <= task.success.e_w;
    // Counted only when more than the last step must be within (no store otherwise).
    let held = if ctx.hold_steps > 1 {
        slot.held = if within {
            slot.held.saturating_add(1)
        } else {
            0
        };
        slot.held >= ctx.hold_steps
    } else {
        within
    };
    let mut ev = 0;
    if terminated || truncated {
        ev |= event::ENDED;
        if !terminated && held {
            ev |= event::SUCCESS;
        }
    }
    if off_track {
        ev |= event::OUT_OF_TRACK;
    }
    if failed {
        ev |= event::NUMERICAL_FAILURE;
    }
    if fell {
        ev |= event::FELL;
    }
    ev
}

/// Whether a step that reached `e_q` ends its episode by a fall: beyond `limit` after
/// `arm_steps` consecutive earlier steps within it (`limit` 0: never). Counts those
/// steps in the slot; a step beyond the limit before the fall is armed starts the count
/// again.
#[inline(always)]
fn falls(limit: f64, arm_steps: u16, e_q: f64, slot: &mut Slot) -> bool {
    if limit <= 0.0 {
        return false;
    }
    let armed = slot.caught >= arm_steps;
    if e_q <= limit {
        if !armed {
            slot.caught += 1;
        }
        return false;
    }
    if !armed {
        slot.caught = 0;
    }
    armed
}

/// One control period of one env (or its next-step autoreset).
fn step_env<G: Geometry, T: Real, A: Real>(
    ctx: &Ctx<'_, G>,
    worker: &mut Worker<G, MeasureInto>,
    mut e: EnvMut<'_>,
    o: EnvOut<'_, T, A>,
) {
    let Worker {
        stepper,
        chain: scratch,
        ..
    } = worker;
    if e.slot.ended {
        // Next-step autoreset (the other modes never get here: same-step resets at
        // once, disabled is refused before stepping).
        autoreset_step(ctx, scratch, e, o);
        return;
    }
    let task = ctx.task;
    let mut force = [0.0; 3];
    let a2 = actuate(task, &mut e, o.action, &mut force[..G::Cart::DIM]);
    let chain = env_chain(ctx, scratch, &e.params);
    let status = stepper.step(
        chain,
        e.y,
        G::Cart::load(&force),
        task.dt,
        &task.step_options,
        &task.guard,
    );
    let m = measure(
        chain.layout(),
        e.y,
        task.target_of(e.slot.goal),
        &ctx.reward,
        a2,
    );
    let mut o = o;
    finish_step(ctx, chain, &mut e, &mut o, status, &m);
    emit_obs(task, chain.layout(), &mut e, o.obs);
}

/// After env `e`'s physics (status `status`, measures `m` of the state it holds and
/// the step's reward): step count, reward, flags and events, diagnostics (on
/// `chain`, the env's own) and the end of the episode (same-step reset or "ended").
/// The caller writes the observation. Returns whether the env was reset (its
/// parameters may have changed).
#[inline(always)]
fn finish_step<G: Geometry, T: Real, A: Real>(
    ctx: &Ctx<'_, G>,
    chain: &Chain<G>,
    e: &mut EnvMut<'_>,
    o: &mut EnvOut<'_, T, A>,
    status: StepStatus,
    m: &StateMeasure,
) -> bool {
    let task = ctx.task;
    e.slot.steps += 1;
    let ev = score(ctx, m, e.slot, status.is_failure(), o);
    *o.event = ev;
    if ctx.diagnostics {
        write_diagnostics(chain, e.y, o.diag);
    }
    if ev & event::ENDED == 0 {
        return false;
    }
    if ctx.mode != AutoresetMode::SameStep {
        e.slot.ended = true;
        return false;
    }
    let d = e.y.len();
    if e.noisy_obs.is_empty() {
        o.finals[..d].copy_from_slice(e.y);
    } else {
        // The final observation is a reading like any other (noise drawn, counts kept).
        sense(task, chain.layout(), e, false);
        o.finals[..d].copy_from_slice(e.noisy_obs);
    }
    write_goal(task, e.slot.goal, &mut o.finals[d..]);
    reset_env(ctx, e);
    true
}
