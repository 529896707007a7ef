//! Steps envs stored env-major (the batch layout) through the lane kernel: each
//! group of `L` consecutive envs is transposed into one component-major lane group,
//! stepped together, and only the lanes whose step succeeded are written back, so a
//! failed env keeps its last good state without a backup copy and without touching
//! its neighbours.

use super::dispatch::{run_guarded_rk4, Kernel};
use super::params::LaneParams;
use super::rk4::{LaneWorkspace, StepSpec};
use super::simd::Lanes;
use super::vector::{LaneGeometry, LaneVector};
use crate::batch::{Guard, StepStatus};

/// How a control period is stepped: period, integrator substeps, failure guard.
#[derive(Debug, Clone, Copy)]
pub struct StepPlan<'a> {
    pub dt: f64,
    pub substeps: usize,
    pub guard: &'a Guard,
}

/// The buffers of one worker's lane groups, allocated once.
#[derive(Debug, Clone)]
pub struct LaneStepper<G: LaneGeometry<L>, const L: usize> {
    ws: LaneWorkspace<G, L>,
}

impl<G: LaneGeometry<L>, const L: usize> LaneStepper<G, L> {
    pub fn new(n_links: usize) -> Self {
        Self {
            ws: LaneWorkspace::new(n_links),
        }
    }

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
        params: &[LaneParams<L>],
        states: &mut [f64],
        forces: &[f64],
        stepped: Option<&[bool]>,
        plan: StepPlan<'_>,
        status: &mut [StepStatus],
    ) {
        let d = self.state_dim();
        let n_envs = status.len();
        debug_assert_eq!(states.len(), n_envs * d);
        for (group, first) in (0..n_envs).step_by(L).enumerate() {
            let filled = L.min(n_envs - first);
            if stepped.is_some_and(|s| !s[first..first + filled].contains(&true)) {
                continue;
            }
            self.gather(states, forces, first, filled);
            let spec = StepSpec {
                params: &params[if params.len() == 1 { 0 } else { group }],
                dt: plan.dt,
                substeps: plan.substeps,
                guard: plan.guard,
            };
            let verdict = run_guarded_rk4(kernel, spec, &mut self.ws);
            for (lane, &lane_status) in verdict[..filled].iter().enumerate() {
                let env = first + lane;
                if stepped.is_some_and(|s| !s[env]) {
                    continue;
                }
                status[env] = lane_status;
                if !lane_status.is_failure() {
                    for (j, v) in states[env * d..(env + 1) * d].iter_mut().enumerate() {
                        *v = self.ws.y[j].0[lane];
                    }
                }
            }
        }
    }

    /// Transposes envs `first..first + filled` into the lanes; lanes past the end
    /// repeat the first env (their results are discarded).
    fn gather(&mut self, states: &[f64], forces: &[f64], first: usize, filled: usize) {
        let d = self.state_dim();
        let f = G::CartL::DIM;
        let mut force = [Lanes::<L>::zero(); 3];
        for lane in 0..L {
            let env = first + if lane < filled { lane } else { 0 };
            for (j, &v) in states[env * d..(env + 1) * d].iter().enumerate() {
                self.ws.y[j].0[lane] = v;
            }
            for (c, component) in force.iter_mut().enumerate().take(f) {
                component.0[lane] = forces[env * f + c];
            }
        }
        self.ws.force = G::CartL::load(&force, 0);
    }
}
