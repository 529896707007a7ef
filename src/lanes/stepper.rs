//! Steps envs through the lane kernel, `L` consecutive envs per lane group, from
//! either layout: env-major rows (each group is transposed into one component-major
//! lane group, stepped, and only the lanes whose step succeeded are written back),
//! or groups that stay component-major between steps ([`super::LaneStates`], no
//! transposes; a lane that failed or was not to step is put back where it started).
//! Either way a failed env keeps its last good state and its neighbours are untouched.

// Index loops on purpose: they must inline into the dispatched kernels.
#![allow(clippy::needless_range_loop)]

use super::dispatch::{run_on, Kernel, LaneWork};
use super::guarded_rk4::{guarded_rk4, roll_back, LaneWorkspace, StepSpec};
use super::hook::{AfterStep, NoHook};
use super::lane_vectors::{LaneGeometry, LaneVector};
use super::params::LaneParams;
use super::simd::{LaneReal, Lanes};
use super::transpose::RowMover;
use crate::integrate::{Guard, StepStatus};

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

/// The envs of one step and where their results go.
pub struct Groups<'a, const L: usize, T: LaneReal = f64> {
    /// Parameters of each group of lanes (or one broadcast entry for all).
    pub params: &'a [LaneParams<L, T>],
    /// One force per env.
    pub forces: &'a [f64],
    /// Which envs step (all when `None`).
    pub stepped: Option<&'a [bool]>,
    /// Period, substeps and guard.
    pub plan: StepPlan<'a>,
    /// Where each env's status goes (one per env: its length is the number of envs).
    pub status: &'a mut [StepStatus],
}

impl<const L: usize, T: LaneReal> Groups<'_, L, T> {
    /// The step of group `group`, whose first env is `first`.
    #[inline(always)]
    fn spec(&self, group: usize) -> StepSpec<'_, L, T> {
        StepSpec {
            params: &self.params[if self.params.len() == 1 { 0 } else { group }],
            dt: self.plan.dt,
            substeps: self.plan.substeps,
            guard: self.plan.guard,
        }
    }

    /// Whether no env of envs `first..first + filled` steps.
    #[inline(always)]
    fn idle(&self, first: usize, filled: usize) -> bool {
        self.stepped
            .is_some_and(|s| !s[first..first + filled].contains(&true))
    }

    /// Writes the statuses of the group's stepped envs; returns, per lane, whether
    /// the lane holds a result to keep (a stepped env whose step succeeded).
    #[inline(always)]
    fn record(&mut self, first: usize, filled: usize, verdict: &[StepStatus; L]) -> [bool; L] {
        let mut keep = [false; L];
        for lane in 0..filled {
            let env = first + lane;
            if self.stepped.is_some_and(|s| !s[env]) {
                continue;
            }
            self.status[env] = verdict[lane];
            keep[lane] = !verdict[lane].is_failure();
        }
        keep
    }
}

/// The buffers of one worker's lane groups, allocated once.
#[derive(Debug, Clone)]
pub struct LaneStepper<G: LaneGeometry<L, T>, const L: usize, T: LaneReal = f64> {
    ws: LaneWorkspace<G, L, T>,
    /// The group being stepped when the envs come as rows.
    group: Vec<Lanes<L, T>>,
}

impl<G: LaneGeometry<L, T>, const L: usize, T: LaneReal> LaneStepper<G, L, T> {
    /// A stepper for chains of `n_links` links.
    pub fn new(n_links: usize) -> Self {
        let ws = LaneWorkspace::new(n_links);
        let group = vec![Lanes::zero(); ws.lay.dim()];
        Self { ws, group }
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
        let groups = Groups {
            params,
            forces,
            stepped,
            plan,
            status,
        };
        self.step_rows(kernel, states, groups, NoHook);
    }

    /// Steps the rows of `states` group by group, running `after` on each stepped group.
    fn step_rows<A: AfterStep<G, L, T>>(
        &mut self,
        kernel: Kernel,
        states: &mut [f64],
        groups: Groups<'_, L, T>,
        after: A,
    ) {
        debug_assert_eq!(states.len(), groups.status.len() * self.state_dim());
        run_on(
            kernel,
            StepRows {
                ws: &mut self.ws,
                group: &mut self.group,
                states,
                groups,
                after,
            },
        );
    }

    /// [`LaneStepper::step`] for envs kept in lane groups: `lanes` holds
    /// `status.len().div_ceil(L)` groups of `state_dim` lanes each (see
    /// [`super::LaneStates`]), stepped in place. A lane whose step failed, or that was
    /// not to step, is put back where it started; lanes past the last env step like
    /// the others under the first env's force and report nothing.
    #[allow(clippy::too_many_arguments)]
    pub fn step_lanes(
        &mut self,
        kernel: Kernel,
        params: &[LaneParams<L, T>],
        lanes: &mut [Lanes<L, T>],
        forces: &[f64],
        stepped: Option<&[bool]>,
        plan: StepPlan<'_>,
        status: &mut [StepStatus],
    ) {
        debug_assert_eq!(lanes.len(), status.len().div_ceil(L) * self.state_dim());
        let groups = Groups {
            params,
            forces,
            stepped,
            plan,
            status,
        };
        run_on(
            kernel,
            StepLanes::<G, L, T> {
                ws: &mut self.ws,
                lanes,
                groups,
            },
        );
    }
}

impl<G: LaneGeometry<L, T>, const L: usize, T: LaneReal> LaneStepper<G, L, T> {
    /// [`LaneStepper::step`], running `after` on each stepped group right after its
    /// step (see [`AfterStep`]; lanes of failed envs hold garbage then).
    #[allow(clippy::too_many_arguments)]
    pub fn step_with<A: AfterStep<G, L, T>>(
        &mut self,
        kernel: Kernel,
        params: &[LaneParams<L, T>],
        states: &mut [f64],
        forces: &[f64],
        stepped: Option<&[bool]>,
        plan: StepPlan<'_>,
        status: &mut [StepStatus],
        after: A,
    ) {
        let groups = Groups {
            params,
            forces,
            stepped,
            plan,
            status,
        };
        self.step_rows(kernel, states, groups, after);
    }
}

/// [`LaneStepper::step`]'s work: transpose in, step, `after`, transpose out, group by
/// group.
struct StepRows<'a, 'b, G: LaneGeometry<L, T>, const L: usize, T: LaneReal, A> {
    ws: &'a mut LaneWorkspace<G, L, T>,
    group: &'a mut [Lanes<L, T>],
    states: &'a mut [f64],
    groups: Groups<'b, L, T>,
    after: A,
}

impl<G: LaneGeometry<L, T>, const L: usize, T: LaneReal, A: AfterStep<G, L, T>> LaneWork
    for StepRows<'_, '_, G, L, T, A>
{
    #[inline(always)]
    fn run<R: RowMover>(self) {
        let Self {
            ws,
            group: y,
            states,
            groups: mut g,
            mut after,
        } = self;
        let d = ws.lay.dim();
        let num_envs = g.status.len();
        for (group, first) in (0..num_envs).step_by(L).enumerate() {
            let filled = L.min(num_envs - first);
            if g.idle(first, filled) {
                continue;
            }
            R::rows_to_lanes(states, d, first, filled, y);
            ws.force = gather_forces::<G, L, T>(g.forces, first, filled);
            let verdict = guarded_rk4(g.spec(group), ws, y);
            let write = g.record(first, filled, &verdict);
            after.group(ws.lay, y, first, filled);
            R::lanes_to_rows(y, states, d, first, &write);
        }
    }
}

/// [`LaneStepper::step_lanes`]'s work: step each group in place, roll back what must
/// not move.
struct StepLanes<'a, 'b, G: LaneGeometry<L, T>, const L: usize, T: LaneReal> {
    ws: &'a mut LaneWorkspace<G, L, T>,
    lanes: &'a mut [Lanes<L, T>],
    groups: Groups<'b, L, T>,
}

impl<G: LaneGeometry<L, T>, const L: usize, T: LaneReal> LaneWork for StepLanes<'_, '_, G, L, T> {
    #[inline(always)]
    fn run<R: RowMover>(self) {
        let Self {
            ws,
            lanes,
            groups: mut g,
        } = self;
        let d = ws.lay.dim();
        let num_envs = g.status.len();
        for (group, y) in lanes.chunks_exact_mut(d).enumerate() {
            let first = group * L;
            let filled = L.min(num_envs - first);
            if g.idle(first, filled) {
                continue;
            }
            ws.force = gather_forces::<G, L, T>(g.forces, first, filled);
            let verdict = guarded_rk4(g.spec(group), ws, y);
            let keep = g.record(first, filled, &verdict);
            // Lanes past the last env are nobody's; they are rolled back on failure
            // only so that a blow-up does not stay in the group.
            let back: [bool; L] = std::array::from_fn(|k| {
                if k < filled {
                    !keep[k]
                } else {
                    verdict[k].is_failure()
                }
            });
            if back.contains(&true) {
                roll_back(ws, y, &back);
            }
        }
    }
}

/// The forces of envs `first..first + filled` in lanes; lanes past the end repeat
/// the first env's.
#[inline(always)]
fn gather_forces<G: LaneGeometry<L, T>, const L: usize, T: LaneReal>(
    forces: &[f64],
    first: usize,
    filled: usize,
) -> G::CartL {
    let f = G::CartL::DIM;
    let mut force = [Lanes::<L, T>::zero(); 3];
    for lane in 0..L {
        let env = first + if lane < filled { lane } else { 0 };
        let push = &forces[env * f..(env + 1) * f];
        for c in 0..f {
            force[c].0[lane] = T::from_f64(push[c]);
        }
    }
    G::CartL::load(&force, 0)
}
