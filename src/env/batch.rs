//! N envs of one task, stepped together on the batch [`Engine`]: physics, reward,
//! termination, success and autoreset in one pass over each fixed chunk of envs,
//! chunks in parallel.
//!
//! Each env owns a ChaCha8 stream (seeded `seed + i` for env i), its step count and
//! its "episode ended" flag, so env i of a batch seeded with `seed` behaves exactly as
//! a batch of one seeded with `seed + i`, and the engine's chunking (fixed, [`CHUNK`] envs)
//! makes results independent of the thread count. Nothing is allocated in
//! [`EnvBatch::step`] or [`EnvBatch::reset`].
//!
//! With rk4, batches of [`crate::engine::MIN_LANE_ENVS`] or more envs step their physics through the
//! lane kernel of [`crate::lanes`] (one env per SIMD lane, each env with its own
//! parameters when they are randomised), which gives every env the same bits as the
//! env-by-env path; [`EnvBatch::set_precision`] trades that for f32 lanes.

use super::config::{AutoresetMode, Start, TaskConfig};
use super::measure::{MeasureInto, RewardSpec};
use super::outputs::{event, Real, StepOutputs, DIAGNOSTICS};
use super::reality::{EnvParams, FORCE_NOISE_STREAM, NOISE_STREAM, PARAM_STREAM};
use super::start::base_state;
use super::step::{
    reset_env, run_chunk, sense, write_goal, write_obs, Ctx, EnvData, Pass, Slot, Widths,
};
use crate::engine::{Engine, Shared, StateHome, CHUNK};
use crate::error::{InputError, Result};
use crate::lanes::{Kernel, LaneScene, Precision};
use crate::model::Chain;
use crate::params::{ChainParams, Rig};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// A saved copy of everything that evolves (states, RNG streams, step counts, ended
/// flags), enough to continue a batch identically after [`EnvBatch::restore`].
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    /// Every env's state, env-major.
    pub states: Vec<f64>,
    /// Per env: ChaCha8 key (32 bytes), stream (8, little-endian) and word position
    /// (16, little-endian).
    pub rng: Vec<[u8; RNG_BYTES]>,
    /// Per env: steps taken in the current episode.
    pub steps: Vec<u64>,
    /// Per env: the episode has ended and awaits its reset.
    pub ended: Vec<bool>,
    /// Per env: consecutive steps within the success tolerances.
    pub held: Vec<u32>,
    /// Per env: consecutive steps within `fall_limit`, counted up to where a fall is armed.
    pub caught: Vec<u16>,
    /// Per env: the episode's (start, target) pair of a goal-conditioned task.
    pub goal: Vec<u16>,
    /// Per env: the episode's control delay (control periods).
    pub action_delays: Vec<u32>,
    /// Per env, the parameter and observation-noise streams (empty when off).
    pub param_rng: Vec<[u8; RNG_BYTES]>,
    /// Per env: the observation-noise stream (same layout as `rng`).
    pub noise_rng: Vec<[u8; RNG_BYTES]>,
    /// Per-env parameters (empty vectors when the batch shares one set).
    pub params: EnvParams,
    /// Each env's current noisy observation, delayed actions and last applied force
    /// (empty when the feature is off).
    pub noisy_obs: Vec<f64>,
    /// Per env: the delayed actions, oldest first.
    pub action_queue: Vec<f64>,
    /// Per env: the force applied last (for the rate limit).
    pub last_force: Vec<f64>,
    /// Per env: the force-noise stream (same layout as `rng`; empty when off).
    pub force_rng: Vec<[u8; RNG_BYTES]>,
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
pub struct EnvBatch<G: LaneScene> {
    /// The nominal model (what the task reports and a controller designer knows).
    chain: Chain<G>,
    /// Steps the true system all envs share (the nominal one unless mismatched); with
    /// randomisation, the centre each env's parameters are drawn around.
    engine: Engine<G, MeasureInto>,
    task: TaskConfig,
    /// The start state before noise (goal-conditioned: one per pair).
    base: Vec<f64>,
    reward: RewardSpec,
    mode: AutoresetMode,
    diagnostics: bool,
    num_envs: usize,
    widths: Widths,
    data: EnvData,
    events: Vec<u8>,
    /// `(e_q, e_w)` per env after the last step (before any same-step reset).
    errors: Vec<f64>,
    /// Same-step mode: the last observation of each env whose episode ended on the
    /// last step.
    finals: Vec<f64>,
    diag: Vec<f64>,
    /// Per-env parameters changed since the lane paths last loaded them.
    lane_params_stale: bool,
}

/// The shared read-only context of a step or reset, from the batch's fields.
macro_rules! ctx {
    ($b:expr) => {
        Ctx {
            chain: $b.engine.chain(),
            truth: $b.engine.chain().params(),
            task: &$b.task,
            base: &$b.base,
            reward: $b.reward,
            hold_steps: $b.task.hold_steps(),
            fall_arm_steps: $b.task.fall_arm_steps(),
            mode: $b.mode,
            diagnostics: $b.diagnostics,
            widths: $b.widths,
            reload_params: $b.lane_params_stale,
        }
    };
}

/// Env `k`'s generator streams for `seed`: start states, parameters, observation
/// noise, force noise.
fn seed_env(data: &mut EnvData, k: usize, seed: u64) {
    data.start_rngs[k] = ChaCha8Rng::seed_from_u64(seed);
    let stream = |s| {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(s);
        rng
    };
    if let Some(r) = data.param_rngs.get_mut(k) {
        *r = stream(PARAM_STREAM);
    }
    if let Some(r) = data.noise_rngs.get_mut(k) {
        *r = stream(NOISE_STREAM);
    }
    if let Some(r) = data.force_rngs.get_mut(k) {
        *r = stream(FORCE_NOISE_STREAM);
    }
}

/// A task checked against one chain: every check a batch makes (the task's fields and
/// precision, the reality gap, the start state), done once. Only [`CheckedTask::new`]
/// makes one, so [`EnvBatch::from_checked`] builds envs from it without checking again.
#[derive(Debug, Clone)]
pub struct CheckedTask<G: LaneScene> {
    chain: Chain<G>,
    true_chain: Chain<G>,
    task: TaskConfig,
    base: Vec<f64>,
}

impl<G: LaneScene> CheckedTask<G> {
    /// `task` on `chain`, checked; the error names the first bad value.
    pub fn new(chain: Chain<G>, task: TaskConfig) -> Result<Self> {
        let (true_chain, base) = check_task(&chain, &task)?;
        Ok(Self {
            chain,
            true_chain,
            task,
            base,
        })
    }
    /// The nominal model.
    pub fn chain(&self) -> &Chain<G> {
        &self.chain
    }
    /// The task.
    pub fn task(&self) -> &TaskConfig {
        &self.task
    }
}

impl<G: LaneScene> EnvBatch<G> {
    /// `num_envs` envs, env i seeded with `seed + i` (wrapping) and reset once: `task`
    /// checked on `chain` ([`CheckedTask::new`]), then [`EnvBatch::from_checked`].
    pub fn new(
        chain: Chain<G>,
        task: TaskConfig,
        num_envs: usize,
        seed: u64,
        mode: AutoresetMode,
        diagnostics: bool,
    ) -> Result<Self> {
        Self::from_checked(
            CheckedTask::new(chain, task)?,
            num_envs,
            seed,
            mode,
            diagnostics,
        )
    }

    /// `num_envs` envs of a checked task, env i seeded with `seed + i` (wrapping) and
    /// reset once.
    pub fn from_checked(
        checked: CheckedTask<G>,
        num_envs: usize,
        seed: u64,
        mode: AutoresetMode,
        diagnostics: bool,
    ) -> Result<Self> {
        let CheckedTask {
            chain,
            true_chain,
            task,
            base,
        } = checked;
        let d = chain.state_dim();
        let widths = Widths::new(&chain, &task);
        let reward = RewardSpec::of(&task, chain.n_links());
        let shared = Shared {
            chain: true_chain,
            dt: task.dt,
            opts: task.step_options,
            guard: task.guard,
        };
        let hook = MeasureInto::new(&task.target, reward, CHUNK, task.transitions.is_some());
        let per_env = widths.param_scalars == 1;
        let engine = Engine::new(
            shared,
            num_envs,
            StateHome::Rows,
            per_env,
            task.precision,
            hook,
        )?;
        let true_params = engine.chain().params();
        let unseeded = ChaCha8Rng::seed_from_u64(0);
        let mut data = EnvData {
            states: vec![0.0; num_envs * d],
            slots: vec![Slot::default(); num_envs],
            start_rngs: vec![unseeded.clone(); num_envs],
            params: match engine.chain().rig() {
                Some(rig) if widths.rig_scalars == 1 => {
                    EnvParams::filled_with_rig(true_params, rig, num_envs)
                }
                _ if per_env => EnvParams::filled(true_params, num_envs),
                _ => EnvParams::empty(chain.n_links()),
            },
            param_rngs: vec![unseeded.clone(); num_envs * widths.param_scalars],
            noise_rngs: vec![unseeded.clone(); num_envs * widths.noise_rng],
            noisy_obs: vec![0.0; num_envs * widths.noisy],
            queue: vec![0.0; num_envs * widths.queue],
            last_force: vec![0.0; num_envs * widths.last_force],
            force_rngs: vec![unseeded; num_envs * widths.force_rng],
        };
        for k in 0..num_envs {
            seed_env(&mut data, k, seed.wrapping_add(k as u64));
        }
        let mut batch = Self {
            task,
            base,
            reward,
            mode,
            diagnostics,
            num_envs,
            widths,
            data,
            events: vec![0; num_envs],
            errors: vec![0.0; 2 * num_envs],
            finals: vec![0.0; num_envs * widths.obs],
            diag: vec![0.0; DIAGNOSTICS.len() * num_envs],
            chain,
            engine,
            lane_params_stale: true,
        };
        for env in 0..num_envs {
            batch.reset_one(env);
        }
        Ok(batch)
    }

    /// The nominal model.
    pub fn chain(&self) -> &Chain<G> {
        &self.chain
    }
    /// The task.
    pub fn task(&self) -> &TaskConfig {
        &self.task
    }
    /// How ended episodes are reset.
    pub fn mode(&self) -> AutoresetMode {
        self.mode
    }
    /// Whether every step records energies and residuals.
    pub fn diagnostics_enabled(&self) -> bool {
        self.diagnostics
    }
    /// Number of envs.
    pub fn num_envs(&self) -> usize {
        self.num_envs
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
        &self.data.states
    }
    /// Env `env`'s state.
    pub fn state(&self, env: usize) -> &[f64] {
        let d = self.state_dim();
        &self.data.states[env * d..(env + 1) * d]
    }
    /// Steps taken in each env's current episode.
    pub fn step_count(&self, env: usize) -> u64 {
        self.data.slots[env].steps
    }
    /// Whether env's episode has ended and it has not been reset since.
    pub fn has_ended(&self, env: usize) -> bool {
        self.data.slots[env].ended
    }
    /// The true parameters shared by the envs before randomisation: the nominal ones
    /// with the task's parameter replacement and mismatch applied.
    pub fn true_params(&self) -> &ChainParams {
        self.engine.chain().params()
    }
    /// Env `env`'s current true parameters (its own draw when randomised).
    pub fn env_params(&self, env: usize) -> Result<ChainParams> {
        self.check_env(env)?;
        if self.widths.param_scalars == 1 {
            self.data.params.get(env)
        } else {
            Ok(self.true_params().clone())
        }
    }
    /// Whether each env draws its own joint damping and cart friction at its resets.
    pub fn draws_rig(&self) -> bool {
        self.data.params.has_rig()
    }
    /// Env `env`'s current rig effects: its own draw where `randomize` draws joint
    /// damping or cart friction, else the true system's (the ideal rig when it has none).
    pub fn env_rig(&self, env: usize) -> Result<Rig> {
        self.check_env(env)?;
        let base = self.engine.chain().rig().cloned().unwrap_or_default();
        self.data.params.rig(env, &base)
    }
    /// The per-env parameter arrays (struct of arrays over the envs) when parameters
    /// are per env, `None` when all envs share [`EnvBatch::true_params`].
    pub fn per_env_params(&self) -> Option<&EnvParams> {
        (self.widths.param_scalars == 1).then_some(&self.data.params)
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

    /// The lane kernel stepping the physics, or `None` when envs step one by one.
    pub fn kernel(&self) -> Option<Kernel> {
        self.engine.kernel()
    }

    /// Number type of the physics (f64 unless [`EnvBatch::set_precision`] chose f32).
    pub fn precision(&self) -> Precision {
        self.engine.precision()
    }

    /// Chooses the lane kernel (`None`: env by env, in f64); see [`Engine::set_kernel`].
    pub fn set_kernel(&mut self, kernel: Option<Kernel>) -> Result<()> {
        self.engine.set_kernel(kernel)?;
        self.lanes_rebuilt();
        Ok(())
    }

    /// Steps the physics in f64 (the default) or f32 (see [`Engine::set_precision`]).
    /// Observations keep their own dtype.
    pub fn set_precision(&mut self, precision: Precision) -> Result<()> {
        self.engine.set_precision(precision)?;
        self.lanes_rebuilt();
        Ok(())
    }

    /// The lanes may be new: the task's precision says what they run in, and per-env
    /// parameters are loaded into them before the next step.
    fn lanes_rebuilt(&mut self) {
        self.task.precision = self.engine.precision();
        self.lane_params_stale = true;
    }

    /// Numbers per observation: the state, then the target's signs when the task
    /// observes them.
    pub fn obs_dim(&self) -> usize {
        self.widths.obs
    }

    /// Writes every env's current observation (its state cast to `T`, or its last
    /// reading when sensor noise or an encoder is on, then the target's signs when observed)
    /// into `obs`.
    pub fn write_obs<T: Real>(&self, obs: &mut [T]) -> Result<()> {
        let (n, w) = (self.num_envs, &self.widths);
        check_size("obs", obs.len(), n * w.obs)?;
        let current = if w.noisy > 0 {
            &self.data.noisy_obs
        } else {
            &self.data.states
        };
        if w.obs == w.state {
            write_obs(current, obs);
            return Ok(());
        }
        for (k, o) in obs.chunks_exact_mut(w.obs).enumerate() {
            write_obs(&current[k * w.state..(k + 1) * w.state], &mut o[..w.state]);
            write_goal(&self.task, self.data.slots[k].goal, &mut o[w.state..]);
        }
        Ok(())
    }

    /// The target of env `env`'s episode (goal-conditioned tasks draw it at reset).
    pub fn env_target(&self, env: usize) -> Result<&[f64]> {
        self.check_env(env)?;
        Ok(self.task.target_of(self.data.slots[env].goal))
    }

    fn check_env(&self, env: usize) -> Result<()> {
        if env < self.num_envs {
            Ok(())
        } else {
            Err(InputError::InvalidParameter {
                name: "env index",
                value: env as f64,
                expected: "an index below num_envs",
            }
            .into())
        }
    }

    /// Overwrites one env's state (checked like an explicit start state) without
    /// touching its step count or RNG.
    pub fn set_state(&mut self, env: usize, state: &[f64]) -> Result<()> {
        self.check_env(env)?;
        let mut task = self.task.clone();
        task.start = Start::State(state.to_vec());
        let y = base_state(&self.chain, &task)?;
        let w = self.widths;
        let layout = self.chain.layout();
        let mut data = self.data.view();
        let mut e = data.env(env, &w);
        e.y.copy_from_slice(&y);
        // A state put in place is a first reading: no count before it to difference.
        sense(&self.task, layout, &mut e, true);
        Ok(())
    }

    fn reset_one(&mut self, env: usize) {
        let ctx = ctx!(self);
        let mut data = self.data.view();
        let mut e = data.env(env, &ctx.widths);
        reset_env(&ctx, &mut e);
        sense(ctx.task, ctx.chain.layout(), &mut e, true);
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
        let n = self.num_envs;
        if let Some(s) = seeds {
            check_size("seeds", s.len(), n)?;
        }
        if let Some(m) = mask {
            check_size("reset_mask", m.len(), n)?;
        }
        check_size("obs", obs.len(), n * self.widths.obs)?;
        for env in 0..n {
            if mask.is_some_and(|m| !m[env]) {
                continue;
            }
            if let Some(seed) = seeds.and_then(|s| s[env]) {
                seed_env(&mut self.data, env, seed);
            }
            self.reset_one(env);
            self.events[env] = 0;
        }
        self.lane_params_stale = true;
        self.write_obs(obs)
    }

    /// Checks a whole action array before anything is stepped: length `num_envs *
    /// force_dim`, every entry finite, and (autoreset disabled) no env whose episode
    /// has ended. A bad action for one env therefore changes no env.
    pub fn check_actions<A: Real>(&self, actions: &[A]) -> Result<()> {
        check_size("actions", actions.len(), self.num_envs * self.force_dim())?;
        if let Some(index) = actions.iter().position(|a| !a.to_f64().is_finite()) {
            let value = actions[index].to_f64();
            // A vector env's actions are (num_envs, force_dim): name the env.
            return Err(if self.num_envs > 1 {
                InputError::NonFiniteInEnv {
                    name: "actions",
                    env: index / self.force_dim(),
                    component: index % self.force_dim(),
                    value,
                }
            } else {
                InputError::NonFinite {
                    name: "actions",
                    index,
                    value,
                }
            }
            .into());
        }
        if self.mode == AutoresetMode::Disabled {
            if let Some(env) = self.data.slots.iter().position(|s| s.ended) {
                return Err(InputError::InvalidParameter {
                    name: "stepped env",
                    value: env as f64,
                    expected: "an env whose episode has not ended (autoreset_mode \"disabled\": \
                               reset it first with options={\"reset_mask\": ...})",
                }
                .into());
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
        let (n, d) = (self.num_envs, self.widths.obs);
        check_size("obs", out.obs.len(), n * d)?;
        check_size("rewards", out.rewards.len(), n)?;
        check_size("terminated", out.terminated.len(), n)?;
        check_size("truncated", out.truncated.len(), n)?;
        let pass = Pass::new(
            self.data.view(),
            actions,
            out,
            &mut self.events,
            &mut self.errors,
            &mut self.finals,
            &mut self.diag,
            self.widths,
        );
        let (task, base, mode, reward) = (&self.task, &self.base[..], self.mode, self.reward);
        let (diagnostics, widths, reload_params) =
            (self.diagnostics, self.widths, self.lane_params_stale);
        self.engine.run_chunks(pass, |shared, pass, worker| {
            let ctx = Ctx {
                chain: &shared.chain,
                truth: shared.chain.params(),
                task,
                base,
                reward,
                hold_steps: task.hold_steps(),
                fall_arm_steps: task.fall_arm_steps(),
                mode,
                diagnostics,
                widths,
                reload_params,
            };
            run_chunk(&ctx, pass, worker);
        });
        self.lane_params_stale = false;
        Ok(self
            .events
            .iter()
            .filter(|&&e| e & event::ENDED != 0)
            .count())
    }

    /// Everything that evolves, for [`EnvBatch::restore`].
    pub fn snapshot(&self) -> Snapshot {
        let d = &self.data;
        Snapshot {
            states: d.states.clone(),
            rng: d.start_rngs.iter().map(rng_to_bytes).collect(),
            steps: d.slots.iter().map(|s| s.steps).collect(),
            ended: d.slots.iter().map(|s| s.ended).collect(),
            held: d.slots.iter().map(|s| s.held).collect(),
            caught: d.slots.iter().map(|s| s.caught).collect(),
            goal: d.slots.iter().map(|s| s.goal).collect(),
            action_delays: d.slots.iter().map(|s| s.delay).collect(),
            param_rng: d.param_rngs.iter().map(rng_to_bytes).collect(),
            noise_rng: d.noise_rngs.iter().map(rng_to_bytes).collect(),
            params: d.params.clone(),
            noisy_obs: d.noisy_obs.clone(),
            action_queue: d.queue.clone(),
            last_force: d.last_force.clone(),
            force_rng: d.force_rngs.iter().map(rng_to_bytes).collect(),
        }
    }

    /// Continues from a [`Snapshot`] of a batch of the same shape and configuration
    /// (checked: sizes, finite states and parameters).
    pub fn restore(&mut self, snap: &Snapshot) -> Result<()> {
        let d = &mut self.data;
        let n = self.num_envs;
        // Each part of the snapshot against the batch: name, length given, length
        // expected (one line each, which rustfmt would spread over five).
        #[rustfmt::skip]
        let sizes: [(&'static str, usize, usize); 18] = [
            ("snapshot states", snap.states.len(), d.states.len()),
            ("snapshot rng", snap.rng.len(), n),
            ("snapshot steps", snap.steps.len(), n),
            ("snapshot ended", snap.ended.len(), n),
            ("snapshot held", snap.held.len(), n),
            ("snapshot caught", snap.caught.len(), n),
            ("snapshot goal", snap.goal.len(), n),
            ("snapshot action_delays", snap.action_delays.len(), n),
            ("snapshot param_rng", snap.param_rng.len(), d.param_rngs.len()),
            ("snapshot noise_rng", snap.noise_rng.len(), d.noise_rngs.len()),
            ("snapshot params", snap.params.num_envs(), d.params.num_envs()),
            ("snapshot joint_damping", snap.params.joint_damping.len(), d.params.joint_damping.len()),
            ("snapshot cart_viscous_friction", snap.params.cart_viscous_friction.len(), d.params.cart_viscous_friction.len()),
            ("snapshot cart_coulomb_friction", snap.params.cart_coulomb_friction.len(), d.params.cart_coulomb_friction.len()),
            ("snapshot noisy_obs", snap.noisy_obs.len(), d.noisy_obs.len()),
            ("snapshot action_queue", snap.action_queue.len(), d.queue.len()),
            ("snapshot last_force", snap.last_force.len(), d.last_force.len()),
            ("snapshot force_rng", snap.force_rng.len(), d.force_rngs.len()),
        ];
        for (name, got, expected) in sizes {
            check_size(name, got, expected)?;
        }
        crate::error::check_finite("snapshot states", &snap.states)?;
        let longest = self.task.reality.max_action_delay();
        if let Some(&delay) = snap.action_delays.iter().find(|&&k| k as usize > longest) {
            return Err(InputError::InvalidParameter {
                name: "snapshot action_delays",
                value: delay as f64,
                expected: "delays no longer than the batch's action_delay allows",
            }
            .into());
        }
        for k in 0..snap.params.num_envs() {
            snap.params.get(k)?;
            snap.params.rig(k, &crate::params::Rig::default())?;
        }
        d.states.copy_from_slice(&snap.states);
        for (k, slot) in d.slots.iter_mut().enumerate() {
            d.start_rngs[k] = rng_from_bytes(&snap.rng[k]);
            slot.steps = snap.steps[k];
            slot.ended = snap.ended[k];
            slot.held = snap.held[k];
            slot.caught = snap.caught[k];
            slot.goal = snap.goal[k];
            slot.delay = snap.action_delays[k];
        }
        for (r, b) in d.param_rngs.iter_mut().zip(&snap.param_rng) {
            *r = rng_from_bytes(b);
        }
        for (r, b) in d.noise_rngs.iter_mut().zip(&snap.noise_rng) {
            *r = rng_from_bytes(b);
        }
        for (r, b) in d.force_rngs.iter_mut().zip(&snap.force_rng) {
            *r = rng_from_bytes(b);
        }
        d.params.clone_from(&snap.params);
        d.noisy_obs.copy_from_slice(&snap.noisy_obs);
        d.queue.copy_from_slice(&snap.action_queue);
        d.last_force.copy_from_slice(&snap.last_force);
        self.events.fill(0);
        self.lane_params_stale = true;
        Ok(())
    }
}

/// A length that must be exactly `expected`.
fn check_size(name: &'static str, got: usize, expected: usize) -> Result<()> {
    if got == expected {
        Ok(())
    } else {
        Err(InputError::LengthMismatch {
            name,
            got,
            expected,
        }
        .into())
    }
}

/// Checks `task` against `chain` without building a batch (every check of the task a
/// batch makes: the task's fields and precision, the reality gap, the start state) and
/// returns the true system the envs step and the state episodes start from before noise.
fn check_task<G: LaneScene>(chain: &Chain<G>, task: &TaskConfig) -> Result<(Chain<G>, Vec<f64>)> {
    task.validate(chain.n_links())?;
    task.sensors.validate_for::<G>()?;
    task.reality.validate(chain.n_links(), chain.state_dim())?;
    let true_params = Chain::new(task.reality.true_params(chain.params())?);
    let true_chain = if task.reality.randomize.draws_rig() {
        true_params.with_drawn_rig(task.rig.clone())?
    } else {
        true_params.with_rig(task.rig.clone())?
    };
    let base = match &task.transitions {
        None => base_state(chain, task)?,
        Some(pairs) => {
            // One start state per pair, drawn from at each reset.
            let mut bases = Vec::with_capacity(pairs.len() * chain.state_dim());
            for k in 0..pairs.len() {
                bases.extend(chain.equilibrium(pairs.start(k))?);
            }
            bases
        }
    };
    Ok((true_chain, base))
}
