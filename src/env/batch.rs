//! N envs of one task, stepped together: physics, reward, termination, success and
//! autoreset in one pass over each fixed chunk of envs, chunks in parallel.
//!
//! Each env owns a ChaCha8 stream (seeded `seed + i` for env i), its step count and
//! its "episode ended" flag, so env i of a batch seeded with `seed` behaves exactly as
//! a batch of one seeded with `seed + i`, and the chunking (fixed, [`CHUNK`] envs)
//! makes results independent of the thread count. Nothing is allocated in
//! [`EnvBatch::step`] or [`EnvBatch::reset`].

use super::config::{AutoresetMode, TaskConfig};
use super::start::{base_state, perturb};
use crate::any::AnyChain;
use crate::batch::{CHUNK, MIN_LANE_ENVS};
use crate::error::{ChainError, Result};
use crate::geometry::{Geometry, Layout, Planar, Spatial, Vector};
use crate::integrate::Method;
use crate::lanes::{ChunkWorker, Kernel, LaneChunk, LaneGeometry, StepPlan, LANES};
use crate::model::Chain;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// Bits of [`EnvBatch::events`], one byte per env, set by the last step or reset.
pub mod event {
    /// The episode ended on this step (terminated or truncated).
    pub const ENDED: u8 = 1;
    /// Ended at the time limit, not terminated, with `e_q`, `e_w` within tolerance.
    pub const SUCCESS: u8 = 2;
    /// Terminated because `max |x_k| > track_limit`.
    pub const OUT_OF_TRACK: u8 = 4;
    /// Terminated because the integration failed; the env kept its last good state.
    pub const NUMERICAL_FAILURE: u8 = 8;
    /// Next-step autoreset: this call reset the env instead of stepping it.
    pub const RESET: u8 = 16;
}

/// Diagnostics per env, in this order, when enabled: total, kinetic and potential
/// energy, largest `| |q_i| - 1 |`, largest `|w_i . q_i|` (the length of the columns of
/// [`EnvBatch::diagnostics`]).
pub const DIAGNOSTICS: [&str; 5] = [
    "energy",
    "kinetic_energy",
    "potential_energy",
    "residual_unit_length",
    "residual_tangency",
];

/// Element type of caller-provided observation and action buffers.
pub trait Real: Copy + Send + Sync + 'static {
    fn from_f64(v: f64) -> Self;
    fn to_f64(self) -> f64;
}
impl Real for f32 {
    /// Rounds to nearest, saturating at `+-f32::MAX`: a finite state gives a finite
    /// observation.
    #[inline(always)]
    fn from_f64(v: f64) -> Self {
        v.clamp(-(f32::MAX as f64), f32::MAX as f64) as f32
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self as f64
    }
}
impl Real for f64 {
    #[inline(always)]
    fn from_f64(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
}

/// Per-step outputs written into caller-provided buffers, env-major.
pub struct StepOutputs<'a, T: Real> {
    /// `n_envs * state_dim` observations (the state, cast to `T`).
    pub obs: &'a mut [T],
    pub rewards: &'a mut [f64],
    pub terminated: &'a mut [bool],
    pub truncated: &'a mut [bool],
}

/// Per-env bookkeeping besides the state.
#[derive(Debug, Clone)]
struct Slot {
    rng: ChaCha8Rng,
    steps: u64,
    /// The episode has ended and the env has not been reset since.
    ended: bool,
}

/// Everything a step reads (shared by all chunks).
struct Ctx<'a, G: Geometry> {
    chain: &'a Chain<G>,
    task: &'a TaskConfig,
    base: &'a [f64],
    mode: AutoresetMode,
    diagnostics: bool,
}

/// The mutable slices of one chunk of envs.
struct Chunk<'a, G: Geometry, T: Real, A: Real> {
    states: &'a mut [f64],
    slots: &'a mut [Slot],
    worker: &'a mut ChunkWorker<G>,
    actions: &'a [A],
    obs: &'a mut [T],
    rewards: &'a mut [f64],
    terminated: &'a mut [bool],
    truncated: &'a mut [bool],
    events: &'a mut [u8],
    errors: &'a mut [f64],
    finals: &'a mut [f64],
    diag: &'a mut [f64],
}

/// A saved copy of everything that evolves (states, RNG streams, step counts, ended
/// flags), enough to continue a batch identically after [`EnvBatch::restore`].
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    pub states: Vec<f64>,
    /// Per env: ChaCha8 key (32 bytes), stream (8, little-endian) and word position
    /// (16, little-endian).
    pub rng: Vec<[u8; RNG_BYTES]>,
    pub steps: Vec<u64>,
    pub ended: Vec<bool>,
}

/// Bytes of one env's RNG state in a [`Snapshot`].
pub const RNG_BYTES: usize = 56;

fn rng_to_bytes(rng: &ChaCha8Rng) -> [u8; RNG_BYTES] {
    let mut out = [0u8; RNG_BYTES];
    out[..32].copy_from_slice(&rng.get_seed());
    out[32..40].copy_from_slice(&rng.get_stream().to_le_bytes());
    out[40..].copy_from_slice(&rng.get_word_pos().to_le_bytes());
    out
}

fn rng_from_bytes(b: &[u8; RNG_BYTES]) -> ChaCha8Rng {
    let mut seed = [0u8; 32];
    seed.copy_from_slice(&b[..32]);
    let mut rng = ChaCha8Rng::from_seed(seed);
    let mut stream = [0u8; 8];
    stream.copy_from_slice(&b[32..40]);
    rng.set_stream(u64::from_le_bytes(stream));
    let mut pos = [0u8; 16];
    pos.copy_from_slice(&b[40..]);
    rng.set_word_pos(u128::from_le_bytes(pos));
    rng
}

/// N envs of one task on one chain.
pub struct EnvBatch<G: Geometry> {
    chain: Chain<G>,
    task: TaskConfig,
    base: Vec<f64>,
    mode: AutoresetMode,
    diagnostics: bool,
    n_envs: usize,
    states: Vec<f64>,
    slots: Vec<Slot>,
    workers: Vec<ChunkWorker<G>>,
    events: Vec<u8>,
    /// `(e_q, e_w)` per env after the last step (before any same-step reset).
    errors: Vec<f64>,
    /// Same-step mode: the last state of each env whose episode ended on the last step.
    finals: Vec<f64>,
    diag: Vec<f64>,
}

impl<G: Geometry> EnvBatch<G> {
    /// `n_envs` envs, env i seeded with `seed + i` (wrapping) and reset once.
    pub fn new(
        chain: Chain<G>,
        task: TaskConfig,
        n_envs: usize,
        seed: u64,
        mode: AutoresetMode,
        diagnostics: bool,
    ) -> Result<Self> {
        if n_envs == 0 {
            return Err(ChainError::InvalidParameter {
                name: "num_envs",
                value: 0.0,
                expected: "an integer >= 1",
            });
        }
        task.validate(chain.n_links())?;
        let base = base_state(&chain, &task)?;
        let d = chain.state_dim();
        let slots = (0..n_envs)
            .map(|i| Slot {
                rng: ChaCha8Rng::seed_from_u64(seed.wrapping_add(i as u64)),
                steps: 0,
                ended: false,
            })
            .collect();
        let workers = (0..n_envs.div_ceil(CHUNK))
            .map(|_| ChunkWorker::new(&chain))
            .collect();
        let mut batch = Self {
            task,
            base,
            mode,
            diagnostics,
            n_envs,
            states: vec![0.0; n_envs * d],
            slots,
            workers,
            events: vec![0; n_envs],
            errors: vec![0.0; 2 * n_envs],
            finals: vec![0.0; n_envs * d],
            diag: vec![0.0; DIAGNOSTICS.len() * n_envs],
            chain,
        };
        for env in 0..n_envs {
            batch.reset_one(env);
        }
        Ok(batch)
    }

    pub fn chain(&self) -> &Chain<G> {
        &self.chain
    }
    pub fn task(&self) -> &TaskConfig {
        &self.task
    }
    pub fn mode(&self) -> AutoresetMode {
        self.mode
    }
    pub fn diagnostics_enabled(&self) -> bool {
        self.diagnostics
    }
    pub fn n_envs(&self) -> usize {
        self.n_envs
    }
    /// Length of one state and of one observation.
    pub fn state_dim(&self) -> usize {
        self.chain.state_dim()
    }
    /// Length of one action.
    pub fn force_dim(&self) -> usize {
        self.chain.force_dim()
    }
    /// The state episodes start from before noise.
    pub fn base_state(&self) -> &[f64] {
        &self.base
    }
    /// All states, env-major.
    pub fn states(&self) -> &[f64] {
        &self.states
    }
    pub fn state(&self, env: usize) -> &[f64] {
        let d = self.state_dim();
        &self.states[env * d..(env + 1) * d]
    }
    /// Steps taken in each env's current episode.
    pub fn step_count(&self, env: usize) -> u64 {
        self.slots[env].steps
    }
    /// Whether env's episode has ended and it has not been reset since.
    pub fn has_ended(&self, env: usize) -> bool {
        self.slots[env].ended
    }
    /// [`event`] bits of the last step or reset, one per env.
    pub fn events(&self) -> &[u8] {
        &self.events
    }
    /// `(e_q, e_w)` per env (interleaved) of the state the last step reached, before
    /// any same-step reset.
    pub fn errors(&self) -> &[f64] {
        &self.errors
    }
    /// Same-step mode: env-major last states of the episodes that ended on the last
    /// step (rows of other envs are stale).
    pub fn final_states(&self) -> &[f64] {
        &self.finals
    }
    /// [`DIAGNOSTICS`] per env (env-major) of the last step, if enabled.
    pub fn diagnostics(&self) -> &[f64] {
        &self.diag
    }

    /// Writes every env's observation (its state cast to `T`) into `obs`.
    pub fn write_obs<T: Real>(&self, obs: &mut [T]) -> Result<()> {
        check_size("obs", obs.len(), self.states.len())?;
        for (o, &s) in obs.iter_mut().zip(&self.states) {
            *o = T::from_f64(s);
        }
        Ok(())
    }

    fn check_env(&self, env: usize) -> Result<()> {
        if env < self.n_envs {
            Ok(())
        } else {
            Err(ChainError::InvalidParameter {
                name: "env index",
                value: env as f64,
                expected: "an index below num_envs",
            })
        }
    }

    /// Overwrites one env's state (checked like an explicit start state) without
    /// touching its step count or RNG.
    pub fn set_state(&mut self, env: usize, state: &[f64]) -> Result<()> {
        self.check_env(env)?;
        let mut task = self.task.clone();
        task.start = super::config::Start::State(state.to_vec());
        let y = base_state(&self.chain, &task)?;
        let d = self.state_dim();
        self.states[env * d..(env + 1) * d].copy_from_slice(&y);
        Ok(())
    }

    fn reset_one(&mut self, env: usize) {
        let d = self.chain.state_dim();
        let slot = &mut self.slots[env];
        perturb(
            self.chain.layout(),
            &self.base,
            self.task.start_noise,
            &mut slot.rng,
            &mut self.states[env * d..(env + 1) * d],
        );
        slot.steps = 0;
        slot.ended = false;
    }

    /// Starts new episodes in the envs where `mask` is true (all if `None`). Env k is
    /// first reseeded with `seeds[k]` when that is `Some`, else continues its stream.
    /// Writes all envs' observations (reset or not) into `obs`.
    pub fn reset<T: Real>(
        &mut self,
        seeds: Option<&[Option<u64>]>,
        mask: Option<&[bool]>,
        obs: &mut [T],
    ) -> Result<()> {
        let n = self.n_envs;
        if let Some(s) = seeds {
            check_size("seeds", s.len(), n)?;
        }
        if let Some(m) = mask {
            check_size("reset_mask", m.len(), n)?;
        }
        check_size("obs", obs.len(), self.states.len())?;
        for env in 0..n {
            if mask.is_some_and(|m| !m[env]) {
                continue;
            }
            if let Some(seed) = seeds.and_then(|s| s[env]) {
                self.slots[env].rng = ChaCha8Rng::seed_from_u64(seed);
            }
            self.reset_one(env);
            self.events[env] = 0;
        }
        self.write_obs(obs)
    }

    /// Checks a whole action array before anything is stepped: length `n_envs *
    /// force_dim`, every entry finite, and (autoreset disabled) no env whose episode
    /// has ended. A bad action for one env therefore changes no env.
    pub fn check_actions<A: Real>(&self, actions: &[A]) -> Result<()> {
        check_size("actions", actions.len(), self.n_envs * self.force_dim())?;
        if let Some(index) = actions.iter().position(|a| !a.to_f64().is_finite()) {
            return Err(ChainError::NonFinite {
                name: "actions",
                index,
                value: actions[index].to_f64(),
            });
        }
        if self.mode == AutoresetMode::Disabled {
            if let Some(env) = self.slots.iter().position(|s| s.ended) {
                return Err(ChainError::InvalidParameter {
                    name: "stepped env",
                    value: env as f64,
                    expected: "an env whose episode has not ended (autoreset_mode \"disabled\": \
                               reset it first with options={\"reset_mask\": ...})",
                });
            }
        }
        Ok(())
    }

    /// One control period for every env: env k applies the force
    /// `max_force * clip(actions[k*f..(k+1)*f], -1, 1)`. Writes observations, rewards
    /// and flags into `out` and events, errors, final states and diagnostics into the
    /// batch; returns how many episodes ended. Errors (before any env is touched) on
    /// bad actions or buffer sizes.
    pub fn step<T: Real, A: Real>(
        &mut self,
        actions: &[A],
        out: StepOutputs<'_, T>,
    ) -> Result<usize> {
        self.check_actions(actions)?;
        let (n, d, f) = (self.n_envs, self.state_dim(), self.force_dim());
        check_size("obs", out.obs.len(), n * d)?;
        check_size("rewards", out.rewards.len(), n)?;
        check_size("terminated", out.terminated.len(), n)?;
        check_size("truncated", out.truncated.len(), n)?;
        let ctx = Ctx {
            chain: &self.chain,
            task: &self.task,
            base: &self.base,
            mode: self.mode,
            diagnostics: self.diagnostics,
        };
        let nd = DIAGNOSTICS.len();
        if n <= CHUNK {
            // One chunk: step it on this thread and skip the pool's wake-up cost.
            run_chunk(
                &ctx,
                Chunk {
                    states: &mut self.states,
                    slots: &mut self.slots,
                    worker: &mut self.workers[0],
                    actions,
                    obs: out.obs,
                    rewards: out.rewards,
                    terminated: out.terminated,
                    truncated: out.truncated,
                    events: &mut self.events,
                    errors: &mut self.errors,
                    finals: &mut self.finals,
                    diag: &mut self.diag,
                },
            );
        } else {
            self.states
                .par_chunks_mut(CHUNK * d)
                .zip(self.slots.par_chunks_mut(CHUNK))
                .zip(self.workers.par_iter_mut())
                .zip(actions.par_chunks(CHUNK * f))
                .zip(out.obs.par_chunks_mut(CHUNK * d))
                .zip(out.rewards.par_chunks_mut(CHUNK))
                .zip(out.terminated.par_chunks_mut(CHUNK))
                .zip(out.truncated.par_chunks_mut(CHUNK))
                .zip(self.events.par_chunks_mut(CHUNK))
                .zip(self.errors.par_chunks_mut(CHUNK * 2))
                .zip(self.finals.par_chunks_mut(CHUNK * d))
                .zip(self.diag.par_chunks_mut(CHUNK * nd))
                .for_each(
                    |(
                        (
                            (
                                (
                                    (
                                        (
                                            (((((states, slots), worker), actions), obs), rewards),
                                            terminated,
                                        ),
                                        truncated,
                                    ),
                                    events,
                                ),
                                errors,
                            ),
                            finals,
                        ),
                        diag,
                    )| {
                        run_chunk(
                            &ctx,
                            Chunk {
                                states,
                                slots,
                                worker,
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
                        )
                    },
                );
        }
        Ok(self
            .events
            .iter()
            .filter(|&&e| e & event::ENDED != 0)
            .count())
    }

    /// Everything that evolves, for [`EnvBatch::restore`].
    pub fn snapshot(&self) -> Snapshot {
        Snapshot {
            states: self.states.clone(),
            rng: self.slots.iter().map(|s| rng_to_bytes(&s.rng)).collect(),
            steps: self.slots.iter().map(|s| s.steps).collect(),
            ended: self.slots.iter().map(|s| s.ended).collect(),
        }
    }

    /// Continues from a [`Snapshot`] of a batch of the same shape (checked: sizes,
    /// finite states).
    pub fn restore(&mut self, snap: &Snapshot) -> Result<()> {
        let n = self.n_envs;
        check_size("snapshot states", snap.states.len(), self.states.len())?;
        check_size("snapshot rng", snap.rng.len(), n)?;
        check_size("snapshot steps", snap.steps.len(), n)?;
        check_size("snapshot ended", snap.ended.len(), n)?;
        crate::error::check_finite("snapshot states", &snap.states)?;
        self.states.copy_from_slice(&snap.states);
        for (k, slot) in self.slots.iter_mut().enumerate() {
            slot.rng = rng_from_bytes(&snap.rng[k]);
            slot.steps = snap.steps[k];
            slot.ended = snap.ended[k];
        }
        self.events.fill(0);
        Ok(())
    }
}

impl<G: LaneGeometry<LANES>> EnvBatch<G> {
    /// Steps the physics with the lane kernel (`None`: env by env). Both give the
    /// same bits. Errors if the CPU lacks the kernel or the integrator is not rk4.
    pub fn set_kernel(&mut self, kernel: Option<Kernel>) -> Result<()> {
        if let Some(kernel) = kernel {
            kernel.checked()?;
            if self.task.step_options.method != Method::Rk4 {
                return Err(ChainError::InvalidParameter {
                    name: "kernel",
                    value: kernel as u8 as f64,
                    expected: "None unless the integrator is rk4 (the only one with a lane kernel)",
                });
            }
        }
        for (i, worker) in self.workers.iter_mut().enumerate() {
            let chunk_len = CHUNK.min(self.n_envs - i * CHUNK);
            *worker = ChunkWorker::new(&self.chain);
            if let Some(kernel) = kernel {
                worker.enable_lanes(Box::new(LaneChunk::shared(&self.chain, kernel)), chunk_len);
            }
        }
        Ok(())
    }

    /// Default physics path: the lane kernel for rk4 batches of [`MIN_LANE_ENVS`] or more.
    fn with_default_kernel(mut self) -> Result<Self> {
        if self.task.step_options.method == Method::Rk4 && self.n_envs >= MIN_LANE_ENVS {
            self.set_kernel(Some(Kernel::detect()))?;
        }
        Ok(self)
    }
}

/// A length that must be exactly `expected`.
fn check_size(name: &'static str, got: usize, expected: usize) -> Result<()> {
    if got == expected {
        Ok(())
    } else {
        Err(ChainError::LengthMismatch {
            name,
            got,
            expected,
        })
    }
}

fn run_chunk<G: Geometry, T: Real, A: Real>(ctx: &Ctx<'_, G>, c: Chunk<'_, G, T, A>) {
    let d = ctx.chain.state_dim();
    let f = ctx.chain.force_dim();
    let nd = DIAGNOSTICS.len();
    if c.worker.uses_lanes() {
        // Physics of the whole chunk first, one env per SIMD lane; step_env then
        // reads each env's status.
        for (k, slot) in c.slots.iter().enumerate() {
            let (force, _) = env_force(&c.actions[k * f..(k + 1) * f], ctx.task.max_force);
            c.worker.queue(k, &force, !slot.ended);
        }
        let plan = StepPlan {
            dt: ctx.task.dt,
            substeps: ctx.task.step_options.substeps,
            guard: &ctx.task.guard,
        };
        c.worker.run_queue(c.states, plan);
    }
    for k in 0..c.slots.len() {
        step_env(
            ctx,
            c.worker,
            k,
            &mut c.slots[k],
            &mut c.states[k * d..(k + 1) * d],
            &c.actions[k * f..(k + 1) * f],
            &mut c.obs[k * d..(k + 1) * d],
            EnvOut {
                reward: &mut c.rewards[k],
                terminated: &mut c.terminated[k],
                truncated: &mut c.truncated[k],
                event: &mut c.events[k],
                errors: &mut c.errors[2 * k..2 * k + 2],
                finals: &mut c.finals[k * d..(k + 1) * d],
                diag: &mut c.diag[k * nd..(k + 1) * nd],
            },
        );
    }
}

struct EnvOut<'a> {
    reward: &'a mut f64,
    terminated: &'a mut bool,
    truncated: &'a mut bool,
    event: &'a mut u8,
    errors: &'a mut [f64],
    finals: &'a mut [f64],
    diag: &'a mut [f64],
}

#[inline(always)]
fn write_obs<T: Real>(y: &[f64], obs: &mut [T]) {
    for (o, &s) in obs.iter_mut().zip(y) {
        *o = T::from_f64(s);
    }
}

/// `(sum |q_i - s_i e3|^2, sum |w_i|^2, e_q, e_w)`.
#[inline(always)]
fn distances<G: Geometry>(lay: Layout<G>, y: &[f64], s: &[f64]) -> (f64, f64, f64, f64) {
    let (mut q2, mut w2, mut e_q, mut e_w) = (0.0, 0.0, 0.0, 0.0);
    for (i, &si) in s.iter().enumerate() {
        let dq = (lay.load_q(y, i) - G::down_unit() * si).norm_squared();
        let dw = lay.load_w(y, i).norm_squared();
        q2 += dq;
        w2 += dw;
        e_q += dq.sqrt();
        e_w += dw.sqrt();
    }
    (q2, w2, e_q, e_w)
}

fn write_diagnostics<G: Geometry>(chain: &Chain<G>, y: &[f64], diag: &mut [f64]) {
    let e = chain.energy(y);
    let r = chain.residuals(y);
    diag.copy_from_slice(&[e.total(), e.kinetic, e.potential, r.unit_length, r.tangency]);
}

/// The force an action asks for, `max_force * clip(action, -1, 1)`, and the squared
/// norm of the clipped action.
#[inline(always)]
fn env_force<A: Real>(action: &[A], max_force: f64) -> ([f64; 3], f64) {
    let mut force = [0.0; 3];
    let mut a2 = 0.0;
    for (fk, a) in force.iter_mut().zip(action) {
        let a = a.to_f64().clamp(-1.0, 1.0);
        a2 += a * a;
        *fk = a * max_force;
    }
    (force, a2)
}

#[allow(clippy::too_many_arguments)]
fn step_env<G: Geometry, T: Real, A: Real>(
    ctx: &Ctx<'_, G>,
    worker: &mut ChunkWorker<G>,
    k: usize,
    slot: &mut Slot,
    y: &mut [f64],
    action: &[A],
    obs: &mut [T],
    out: EnvOut<'_>,
) {
    let chain = ctx.chain;
    let task = ctx.task;
    let lay = chain.layout();
    let reset = |slot: &mut Slot, y: &mut [f64]| {
        perturb(lay, ctx.base, task.start_noise, &mut slot.rng, y);
        slot.steps = 0;
        slot.ended = false;
    };
    if slot.ended {
        // Next-step autoreset (the other modes never get here: same-step resets at
        // once, disabled is refused in check_actions).
        reset(slot, y);
        write_obs(y, obs);
        *out.reward = 0.0;
        *out.terminated = false;
        *out.truncated = false;
        *out.event = event::RESET;
        let (_, _, e_q, e_w) = distances(lay, y, &task.target);
        out.errors.copy_from_slice(&[e_q, e_w]);
        if ctx.diagnostics {
            write_diagnostics(chain, y, out.diag);
        }
        return;
    }

    let (force, a2) = env_force(action, task.max_force);
    let status = worker.step_env(
        k,
        chain,
        y,
        G::Cart::load(&force),
        task.dt,
        &task.step_options,
        &task.guard,
    );
    slot.steps += 1;
    let failed = status.is_failure();
    let cart_dim = G::Cart::DIM;
    let off_track = !failed
        && y[lay.x()..lay.x() + cart_dim]
            .iter()
            .any(|x| x.abs() > task.track_limit);
    let terminated = failed || off_track;
    let truncated = slot.steps >= task.max_episode_steps;
    let (q2, w2, e_q, e_w) = distances(lay, y, &task.target);
    let w = &task.reward;
    *out.reward = if failed {
        0.0
    } else {
        let x2 = lay.load_x(y).norm_squared();
        let v2 = lay.load_xdot(y).norm_squared();
        (-(w.q * q2 + w.w * w2 + w.x * x2 + w.v * v2 + w.u * a2)).exp()
    };
    *out.terminated = terminated;
    *out.truncated = truncated;
    out.errors.copy_from_slice(&[e_q, e_w]);
    let mut ev = 0;
    if terminated || truncated {
        ev |= event::ENDED;
        if !terminated && e_q <= task.success.e_q && e_w <= task.success.e_w {
            ev |= event::SUCCESS;
        }
    }
    if off_track {
        ev |= event::OUT_OF_TRACK;
    }
    if failed {
        ev |= event::NUMERICAL_FAILURE;
    }
    *out.event = ev;
    if ctx.diagnostics {
        write_diagnostics(chain, y, out.diag);
    }
    if ev & event::ENDED != 0 {
        if ctx.mode == AutoresetMode::SameStep {
            out.finals.copy_from_slice(y);
            reset(slot, y);
        } else {
            slot.ended = true;
        }
    }
    write_obs(y, obs);
}

/// An env batch in either scene, chosen at run time.
pub enum AnyEnvBatch {
    Spatial(EnvBatch<Spatial>),
    Planar(EnvBatch<Planar>),
}

/// Runs `$body` with `$b` bound to the concrete batch.
macro_rules! dispatch {
    ($self:expr, $b:ident, $body:expr) => {
        match $self {
            AnyEnvBatch::Spatial($b) => $body,
            AnyEnvBatch::Planar($b) => $body,
        }
    };
}

impl AnyEnvBatch {
    pub fn new(
        chain: AnyChain,
        task: TaskConfig,
        n_envs: usize,
        seed: u64,
        mode: AutoresetMode,
        diagnostics: bool,
    ) -> Result<Self> {
        Ok(match chain {
            AnyChain::Spatial(c) => AnyEnvBatch::Spatial(
                EnvBatch::new(c, task, n_envs, seed, mode, diagnostics)?.with_default_kernel()?,
            ),
            AnyChain::Planar(c) => AnyEnvBatch::Planar(
                EnvBatch::new(c, task, n_envs, seed, mode, diagnostics)?.with_default_kernel()?,
            ),
        })
    }
    pub fn is_planar(&self) -> bool {
        matches!(self, AnyEnvBatch::Planar(_))
    }
    pub fn task(&self) -> &TaskConfig {
        dispatch!(self, b, b.task())
    }
    pub fn mode(&self) -> AutoresetMode {
        dispatch!(self, b, b.mode())
    }
    pub fn diagnostics_enabled(&self) -> bool {
        dispatch!(self, b, b.diagnostics_enabled())
    }
    pub fn n_envs(&self) -> usize {
        dispatch!(self, b, b.n_envs())
    }
    pub fn n_links(&self) -> usize {
        dispatch!(self, b, b.chain().n_links())
    }
    pub fn state_dim(&self) -> usize {
        dispatch!(self, b, b.state_dim())
    }
    pub fn force_dim(&self) -> usize {
        dispatch!(self, b, b.force_dim())
    }
    pub fn base_state(&self) -> &[f64] {
        dispatch!(self, b, b.base_state())
    }
    pub fn states(&self) -> &[f64] {
        dispatch!(self, b, b.states())
    }
    pub fn step_count(&self, env: usize) -> u64 {
        dispatch!(self, b, b.step_count(env))
    }
    pub fn has_ended(&self, env: usize) -> bool {
        dispatch!(self, b, b.has_ended(env))
    }
    pub fn events(&self) -> &[u8] {
        dispatch!(self, b, b.events())
    }
    pub fn errors(&self) -> &[f64] {
        dispatch!(self, b, b.errors())
    }
    pub fn final_states(&self) -> &[f64] {
        dispatch!(self, b, b.final_states())
    }
    pub fn diagnostics(&self) -> &[f64] {
        dispatch!(self, b, b.diagnostics())
    }
    pub fn write_obs<T: Real>(&self, obs: &mut [T]) -> Result<()> {
        dispatch!(self, b, b.write_obs(obs))
    }
    pub fn set_state(&mut self, env: usize, state: &[f64]) -> Result<()> {
        dispatch!(self, b, b.set_state(env, state))
    }
    pub fn reset<T: Real>(
        &mut self,
        seeds: Option<&[Option<u64>]>,
        mask: Option<&[bool]>,
        obs: &mut [T],
    ) -> Result<()> {
        dispatch!(self, b, b.reset(seeds, mask, obs))
    }
    pub fn check_actions<A: Real>(&self, actions: &[A]) -> Result<()> {
        dispatch!(self, b, b.check_actions(actions))
    }
    pub fn step<T: Real, A: Real>(
        &mut self,
        actions: &[A],
        out: StepOutputs<'_, T>,
    ) -> Result<usize> {
        dispatch!(self, b, b.step(actions, out))
    }
    pub fn snapshot(&self) -> Snapshot {
        dispatch!(self, b, b.snapshot())
    }
    pub fn restore(&mut self, snap: &Snapshot) -> Result<()> {
        dispatch!(self, b, b.restore(snap))
    }
}
