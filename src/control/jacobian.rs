//! The discrete control step (RK4 with `substeps` steps over the control period, force
//! held, as the env integrates) and its exact derivatives in the chart:
//!
//! `A_k = d local_{y_(k+1)}(step(retract_{y_k}(delta), u_k + v)) / d delta`, `B_k = ... / d v`,
//!
//! by forward-mode differentiation of the generic dynamics, [`DIRECTIONS`] directions
//! per pass, so nothing is allocated per call.

use super::chart::{local, retract, ChartLayout, ChartPoint};
use super::dual::{Dual, Real};
use super::dynamics::{ScalarChain, ScalarWorkspace};
use super::vector::{ScalarGeometry, Vect};
use crate::model::Chain;
use nalgebra::DMatrix;

/// Directions carried by one dual pass.
pub const DIRECTIONS: usize = 8;

/// The scalar of the derivative passes.
pub type D = Dual<DIRECTIONS>;

/// The control step of a chain at a control period, with its derivatives.
#[derive(Debug, Clone)]
pub struct StepModel<G: ScalarGeometry> {
    chain: ScalarChain<G>,
    /// Control period, s.
    pub dt: f64,
    /// RK4 steps per control period.
    pub substeps: usize,
}

/// Buffers of [`StepModel`], one per thread.
#[derive(Debug, Clone)]
pub struct StepWorkspace<G: ScalarGeometry> {
    values: ScalarWorkspace<G, f64>,
    duals: ScalarWorkspace<G, D>,
    delta: Vec<D>,
    force: Vec<D>,
    state: Vec<D>,
    out: Vec<D>,
}

impl<G: ScalarGeometry> StepModel<G> {
    /// The step of `chain` over `dt` with `substeps` RK4 steps (both checked by the caller).
    pub fn new(chain: &Chain<G>, dt: f64, substeps: usize) -> Self {
        Self {
            chain: ScalarChain::new(chain),
            dt,
            substeps,
        }
    }
    /// Number of links.
    pub fn n_links(&self) -> usize {
        self.chain.n_links()
    }
    /// The chart's layout.
    pub fn chart(&self) -> ChartLayout {
        ChartLayout::of::<G>(self.chain.n_links())
    }
    /// Length of a state.
    pub fn state_dim(&self) -> usize {
        self.chain.state_dim()
    }
    /// Length of a force.
    pub fn force_dim(&self) -> usize {
        G::CART
    }
    /// The generic dynamics.
    pub fn dynamics(&self) -> &ScalarChain<G> {
        &self.chain
    }

    /// Fresh buffers.
    pub fn workspace(&self) -> StepWorkspace<G> {
        let n = self.n_links();
        let (dim, nz) = (self.state_dim(), self.chart().dim());
        StepWorkspace {
            values: ScalarWorkspace::new(n),
            duals: ScalarWorkspace::new(n),
            delta: vec![D::cst(0.0); nz],
            force: vec![D::cst(0.0); G::CART],
            state: vec![D::cst(0.0); dim],
            out: vec![D::cst(0.0); nz.max(dim)],
        }
    }

    /// Advances `y` by one control period under `force`.
    pub fn step(&self, y: &mut [f64], force: &[f64], ws: &mut StepWorkspace<G>) {
        self.chain.step(
            y,
            G::CartS::<f64>::load(force),
            self.dt,
            self.substeps,
            &mut ws.values,
        );
    }

    /// `A` (`nz x nz`) and `B` (`nz x force_dim`) of the step from `base` under `force`,
    /// in the charts about `base` and `next` (normally the step's result).
    pub fn jacobians(
        &self,
        base: &ChartPoint,
        force: &[f64],
        next: &ChartPoint,
        a: &mut DMatrix<f64>,
        b: &mut DMatrix<f64>,
        ws: &mut StepWorkspace<G>,
    ) {
        let nz = self.chart().dim();
        let total = nz + G::CART;
        for first in (0..total).step_by(DIRECTIONS) {
            for (j, d) in ws.delta.iter_mut().enumerate() {
                *d = seeded(0.0, j, first);
            }
            for (c, f) in ws.force.iter_mut().enumerate() {
                *f = seeded(force[c], nz + c, first);
            }
            retract::<G, D>(base, &ws.delta, &mut ws.state);
            self.chain.step(
                &mut ws.state,
                G::CartS::<D>::load(&ws.force),
                self.dt,
                self.substeps,
                &mut ws.duals,
            );
            local::<G, D>(next, &ws.state, &mut ws.out[..nz]);
            for j in 0..DIRECTIONS.min(total - first) {
                let col = first + j;
                for (r, o) in ws.out[..nz].iter().enumerate() {
                    if col < nz {
                        a[(r, col)] = o.eps[j];
                    } else {
                        b[(r, col - nz)] = o.eps[j];
                    }
                }
            }
        }
    }

    /// The Jacobian (`m x nz`) of a function `f(y) -> [m values]` of the state, in the
    /// chart about `base`, and its value. `values` and `jacobian` have `m` rows.
    #[allow(clippy::too_many_arguments)]
    pub fn chart_jacobian(
        &self,
        base: &ChartPoint,
        m: usize,
        mut f: impl FnMut(&[D], &mut [D]),
        values: &mut [f64],
        jacobian: &mut DMatrix<f64>,
        ws: &mut StepWorkspace<G>,
        out: &mut Vec<D>,
    ) {
        let nz = self.chart().dim();
        out.resize(m, D::cst(0.0));
        for first in (0..nz).step_by(DIRECTIONS) {
            for (j, d) in ws.delta.iter_mut().enumerate() {
                *d = seeded(0.0, j, first);
            }
            retract::<G, D>(base, &ws.delta, &mut ws.state);
            f(&ws.state, out);
            for j in 0..DIRECTIONS.min(nz - first) {
                for (r, o) in out.iter().enumerate() {
                    jacobian[(r, first + j)] = o.eps[j];
                }
            }
        }
        for (v, o) in values.iter_mut().zip(out.iter()) {
            *v = o.re;
        }
    }
}

/// `value`, with derivative 1 along direction `index` if it is in the pass starting at `first`.
#[inline(always)]
fn seeded(value: f64, index: usize, first: usize) -> D {
    let mut d = D::cst(value);
    if (first..first + DIRECTIONS).contains(&index) {
        d.eps[index - first] = 1.0;
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::Linearization;
    use crate::control::dynamics::tests::test_rigs;
    use crate::geometry::{Planar, Spatial};
    use crate::params::{ChainParams, Rig};
    use rand::{Rng, SeedableRng};

    /// Central differences of the step in the chart, column by column.
    fn finite_differences<G: ScalarGeometry>(
        model: &StepModel<G>,
        base: &ChartPoint,
        force: &[f64],
        next: &ChartPoint,
    ) -> DMatrix<f64> {
        let nz = model.chart().dim();
        let mut ws = model.workspace();
        let mut fd = DMatrix::zeros(nz, nz + G::CART);
        let h = 1e-6;
        let mut y = vec![0.0; model.state_dim()];
        let mut out = vec![0.0; nz];
        for col in 0..nz + G::CART {
            let mut column = vec![0.0; nz];
            for sign in [1.0, -1.0] {
                let mut delta = vec![0.0; nz];
                let mut u = force.to_vec();
                if col < nz {
                    delta[col] = sign * h;
                } else {
                    u[col - nz] += sign * h;
                }
                retract::<G, f64>(base, &delta, &mut y);
                model.step(&mut y, &u, &mut ws);
                local::<G, f64>(next, &y, &mut out);
                for (c, o) in column.iter_mut().zip(&out) {
                    *c += sign * o / (2.0 * h);
                }
            }
            fd.column_mut(col).copy_from_slice(&column);
        }
        fd
    }

    fn matches_finite_differences<G: ScalarGeometry>(n: usize, seed: u64) {
        matches_finite_differences_on::<G>(n, seed, Rig::default());
    }

    fn matches_finite_differences_on<G: ScalarGeometry>(n: usize, seed: u64, rig: Rig) {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let chain = Chain::<G>::new(ChainParams::uniform(n, 1.0, 0.1, 0.5, 9.81).unwrap())
            .with_rig(rig)
            .unwrap();
        let model = StepModel::new(&chain, 0.02, 2);
        let nz = model.chart().dim();
        let mut ws = model.workspace();
        for _ in 0..5 {
            let mut y: Vec<f64> = (0..chain.state_dim())
                .map(|_| rng.random_range(-2.0..2.0))
                .collect();
            chain.project(&mut y);
            let force: Vec<f64> = (0..G::CART)
                .map(|_| rng.random_range(-10.0..10.0))
                .collect();
            let base = ChartPoint::new::<G>(n, &y);
            model.step(&mut y, &force, &mut ws);
            let next = ChartPoint::new::<G>(n, &y);
            let (mut a, mut b) = (DMatrix::zeros(nz, nz), DMatrix::zeros(nz, G::CART));
            model.jacobians(&base, &force, &next, &mut a, &mut b, &mut ws);
            let fd = finite_differences(&model, &base, &force, &next);
            let exact = DMatrix::from_fn(nz, nz + G::CART, |r, c| {
                if c < nz {
                    a[(r, c)]
                } else {
                    b[(r, c - nz)]
                }
            });
            let err = (&exact - &fd).amax();
            assert!(
                err < 1e-6 * (1.0 + exact.amax()),
                "{} n={n}: |exact - fd| = {err:e}, |A| = {}",
                G::NAME,
                exact.amax()
            );
        }
    }

    #[test]
    fn step_derivatives_match_central_differences_planar_and_spatial() {
        for n in [1, 2, 3, 5] {
            matches_finite_differences::<Planar>(n, n as u64);
            matches_finite_differences::<Spatial>(n, 100 + n as u64);
        }
    }

    #[test]
    fn step_derivatives_match_central_differences_on_a_rig() {
        for n in [1, 2, 3] {
            for (k, rig) in test_rigs(n).into_iter().enumerate() {
                let seed = 10 * k as u64 + n as u64;
                matches_finite_differences_on::<Planar>(n, seed, rig.clone());
                matches_finite_differences_on::<Spatial>(n, 500 + seed, rig);
            }
        }
    }

    /// RK4 applied to a linear system is its Taylor polynomial of degree 4: at an
    /// equilibrium the step's Jacobians are those of the paper's linearisation (with a
    /// rig, of the linearisation with its damping, friction and actuation).
    fn rk4_of_the_linearisation_at_an_equilibrium(rig: Rig) {
        let params = ChainParams::uniform(3, 1.0, 0.1, 0.5, 9.81).unwrap();
        let s = [-1.0, 1.0, -1.0];
        let ss = Linearization::with_rig(&params, &s, &rig)
            .unwrap()
            .state_space()
            .unwrap();
        let chain = Chain::<Spatial>::new(params).with_rig(rig).unwrap();
        let (dt, substeps) = (0.02, 2);
        let model = StepModel::new(&chain, dt, substeps);
        let base = ChartPoint::new::<Spatial>(3, &chain.equilibrium(&s).unwrap());
        let (mut a, mut b) = (DMatrix::zeros(16, 16), DMatrix::zeros(16, 2));
        model.jacobians(
            &base,
            &[0.0, 0.0],
            &base,
            &mut a,
            &mut b,
            &mut model.workspace(),
        );
        let h = dt / substeps as f64;
        let ah = &ss.a * h;
        let eye = DMatrix::<f64>::identity(16, 16);
        let a2 = &ah * &ah;
        let taylor = &eye + &ah + &a2 / 2.0 + &a2 * &ah / 6.0 + &a2 * &a2 / 24.0;
        let input = (&eye + &ah / 2.0 + &a2 / 6.0 + &a2 * &ah / 24.0) * &ss.b * h;
        let expected_a = &taylor * &taylor;
        let expected_b = &taylor * &input + &input;
        let tolerance = 1e-12 * (1.0 + expected_a.amax().max(expected_b.amax()));
        assert!(
            (&a - &expected_a).amax() < tolerance,
            "{:e}",
            (&a - &expected_a).amax()
        );
        assert!(
            (&b - &expected_b).amax() < tolerance,
            "{:e}",
            (&b - &expected_b).amax()
        );
    }

    #[test]
    fn at_an_equilibrium_the_step_is_rk4_of_the_linearisation() {
        rk4_of_the_linearisation_at_an_equilibrium(Rig::default());
    }

    #[test]
    fn at_an_equilibrium_on_a_rig_the_step_is_rk4_of_the_rig_linearisation() {
        for rig in test_rigs(3) {
            rk4_of_the_linearisation_at_an_equilibrium(rig);
        }
    }
}
