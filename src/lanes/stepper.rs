//! Steps envs stored env-major (the batch layout) through the lane kernel: each
//! group of `L` consecutive envs is transposed into one component-major lane group,
//! stepped together, and only the lanes whose step succeeded are written back, so a
//! failed env keeps its last good state without a backup copy and without touching
//! its neighbours.

// Index loops on purpose: they must inline into the dispatched kernels.
#![allow(clippy::needless_range_loop)]

use super::dispatch::{run_groups, Kernel};
use super::params::LaneParams;
use super::rk4::{guarded_rk4, LaneWorkspace, StepSpec};
use super::simd::{LaneReal, Lanes};
use super::transpose::RowMover;
use super::vector::{LaneGeometry, LaneVector};
use crate::batch::{Guard, StepStatus};

/// How a control period is stepped: period, integrator substeps, failure guard.
#[derive(Debug, Clone, Copy)]
pub struct StepPlan<'a> {
    /// Control period (s).
    pub dt: f64,
    /// Integrator steps per control period.
    pub substeps: usize,
    /// When a step counts as failed.
    pub guard: &'a Guard,
}

/// The envs of one [`LaneStepper::step`] call and where their results go.
pub struct Groups<'a, const L: usize, T: LaneReal = f64> {
    /// Parameters of each group of lanes.
    pub params: &'a [LaneParams<L, T>],
    /// The envs' states, env-major.
    pub states: &'a mut [f64],
    /// One force per env.
    pub forces: &'a [f64],
    /// Which envs step (all when `None`).
    pub stepped: Option<&'a [bool]>,
    /// Period, substeps and guard.
    pub plan: StepPlan<'a>,
    /// Where each env's status goes.
    pub status: &'a mut [StepStatus],
}

/// The buffers of one worker's lane groups, allocated once.
#[derive(Debug, Clone)]
pub struct LaneStepper<G: LaneGeometry<L, T>, const L: usize, T: LaneReal = f64> {
    ws: LaneWorkspace<G, L, T>,
}

impl<G: LaneGeometry<L, T>, const L: usize, T: LaneReal> LaneStepper<G, L, T> {
    /// A stepper for chains of `n_links` links.
    pub fn new(n_links: usize) -> Self {
        Self {
            ws: LaneWorkspace::new(n_links),
        }
    }

    /// Length of one env's state.
    pub fn state_dim(&self) -> usize {
        self.ws.lay.dim()
    }

    /// Steps every env k of `states` (env-major, `state_dim` each) with `stepped[k]`
    /// true (all if `None`) by one guarded rk4 control period under the force
    /// `forces[k*f..(k+1)*f]`, writing `status[k]`; other envs are left untouched.
    /// Envs `g*L..(g+1)*L` form lane group g and read `params[g]`, or `params[0]`
    /// when one broadcast entry is given for all.
    #[allow(clippy::too_many_arguments)]
    pub fn step(
        &mut self,
        kernel: Kernel,
        params: &[LaneParams<L, T>],
        states: &mut [f64],
        forces: &[f64],
        stepped: Option<&[bool]>,
        plan: StepPlan<'_>,
        status: &mut [StepStatus],
    ) {
        debug_assert_eq!(states.len(), status.len() * self.state_dim());
        let groups = Groups {
            params,
            states,
            forces,
            stepped,
            plan,
            status,
        };
        run_groups(kernel, &mut self.ws, groups);
    }
}

/// [`LaneStepper::step`]'s work: transpose in, step, transpose out, group by group.
/// Inlined into each dispatched kernel so that the transposes get its instructions too.
#[inline(always)]
pub(crate) fn step_groups<R: RowMover, G: LaneGeometry<L, T>, const L: usize, T: LaneReal>(
    ws: &mut LaneWorkspace<G, L, T>,
    g: Groups<'_, L, T>,
) {
    let d = ws.lay.dim();
    let num_envs = g.status.len();
    for (group, first) in (0..num_envs).step_by(L).enumerate() {
        let filled = L.min(num_envs - first);
        if g.stepped
            .is_some_and(|s| !s[first..first + filled].contains(&true))
        {
            continue;
        }
        gather::<R, G, L, T>(ws, g.states, g.forces, first, filled);
        let spec = StepSpec {
            params: &g.params[if g.params.len() == 1 { 0 } else { group }],
            dt: g.plan.dt,
            substeps: g.plan.substeps,
            guard: g.plan.guard,
        };
        let verdict = guarded_rk4(spec, ws);
        let mut write = [false; L];
        for lane in 0..filled {
            let env = first + lane;
            if g.stepped.is_some_and(|s| !s[env]) {
                continue;
            }
            g.status[env] = verdict[lane];
            write[lane] = !verdict[lane].is_failure();
        }
        R::lanes_to_rows(&ws.y, g.states, d, first, &write);
    }
}

/// Transposes envs `first..first + filled` into the lanes; lanes past the end
/// repeat the first env (their results are discarded).
#[inline(always)]
fn gather<R: RowMover, G: LaneGeometry<L, T>, const L: usize, T: LaneReal>(
    ws: &mut LaneWorkspace<G, L, T>,
    states: &[f64],
    forces: &[f64],
    first: usize,
    filled: usize,
) {
    let d = ws.lay.dim();
    let f = G::CartL::DIM;
    R::rows_to_lanes(states, d, first, filled, &mut ws.y);
    let mut force = [Lanes::<L, T>::zero(); 3];
    for lane in 0..L {
        let env = first + if lane < filled { lane } else { 0 };
        let push = &forces[env * f..(env + 1) * f];
        for c in 0..f {
            force[c].0[lane] = T::from_f64(push[c]);
        }
    }
    ws.force = G::CartL::load(&force, 0);
}
