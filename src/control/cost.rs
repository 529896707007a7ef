//! The planner's cost: a smooth global distance to the target equilibrium, a force
//! cost, a smooth penalty near the ends of the track, and at the end the target's LQR
//! cost-to-go.
//!
//! Every state term is a residual `r(y)`, so the cost is `|r|^2 / 2` and its
//! Gauss-Newton Hessian `J^T J` (with `J` the exact Jacobian in the chart) is positive
//! semi-definite everywhere:
//!
//! * running, times `dt`: `[sqrt(w_x) x, sqrt(w_q) (q_i - s_i e3), sqrt(w_v) xdot,
//!   sqrt(w_w) w_i, sqrt(w_track) max(0, |x_c| - margin)]`, plus `w_u |u|^2 / 2`;
//! * terminal: `sqrt(terminal)` times the running state residual (global: it sees every
//!   equilibrium from any state, where the LQR's quadratic is only local), and
//!   `L^T z`, with `z` the chart increment from the target and `P = L L^T` the
//!   stabilising Riccati solution of the running weights at the target: near the target
//!   the terminal cost is the infinite-horizon cost of holding it.
//!
//! `|q_i - s_i e3|^2 = 2 (1 - cos tilt_i)` is the global distance on the sphere the env's
//! reward uses; it has no spurious minimum (only the antipode is a maximum).

use super::chart::{local, ChartLayout, ChartPoint};
use super::dual::Real;
use super::vector::{ScalarGeometry, Vect};
use crate::analysis::{solve_care, Linearization};
use crate::error::{check_positive, ChainError, InputError, Result};
use crate::geometry::Layout;
use crate::model::Chain;
use nalgebra::{Cholesky, DMatrix};

/// Weights of the cost (see the module docs). All `>= 0`, `force > 0`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CostWeights {
    /// Cart position, 1/m^2.
    pub x: f64,
    /// Link direction `|q_i - s_i e3|^2`.
    pub q: f64,
    /// Cart velocity.
    pub v: f64,
    /// Angular velocity.
    pub w: f64,
    /// Force, 1/N^2.
    pub force: f64,
    /// The track penalty beyond `track_margin * track_limit`.
    pub track: f64,
    /// Multiplier of the running state weights in the terminal cost.
    pub terminal: f64,
    /// Where the track penalty starts, as a fraction of the track limit.
    pub track_margin: f64,
}

impl Default for CostWeights {
    fn default() -> Self {
        Self {
            x: 1.0,
            q: 10.0,
            v: 0.5,
            w: 0.2,
            force: 0.2,
            track: 2000.0,
            terminal: 300.0,
            track_margin: 0.8,
        }
    }
}

impl CostWeights {
    /// The weights' names, in the order of the fields.
    pub const NAMES: [&'static str; 8] = [
        "x",
        "q",
        "v",
        "w",
        "force",
        "track",
        "terminal",
        "track_margin",
    ];

    /// Every weight with its name, in the order of [`Self::NAMES`].
    pub fn named(&self) -> [(&'static str, f64); 8] {
        let values = [
            self.x,
            self.q,
            self.v,
            self.w,
            self.force,
            self.track,
            self.terminal,
            self.track_margin,
        ];
        std::array::from_fn(|i| (Self::NAMES[i], values[i]))
    }

    /// The weight called `name`, to set it; `None` for a name not in [`Self::NAMES`].
    pub fn by_name_mut(&mut self, name: &str) -> Option<&mut f64> {
        Some(match name {
            "x" => &mut self.x,
            "q" => &mut self.q,
            "v" => &mut self.v,
            "w" => &mut self.w,
            "force" => &mut self.force,
            "track" => &mut self.track,
            "terminal" => &mut self.terminal,
            "track_margin" => &mut self.track_margin,
            _ => return None,
        })
    }

    /// Checks every weight: finite and >= 0, `force` > 0, `track_margin` in (0, 1].
    pub fn validate(&self) -> Result<()> {
        for (name, value) in [
            ("weights.x", self.x),
            ("weights.q", self.q),
            ("weights.v", self.v),
            ("weights.w", self.w),
            ("weights.track", self.track),
            ("weights.terminal", self.terminal),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(InputError::InvalidParameter {
                    name,
                    value,
                    expected: "a finite number >= 0",
                }
                .into());
            }
        }
        check_positive("weights.force", self.force)?;
        if !(self.track_margin > 0.0 && self.track_margin <= 1.0) {
            return Err(InputError::InvalidParameter {
                name: "weights.track_margin",
                value: self.track_margin,
                expected: "a number in (0, 1]",
            }
            .into());
        }
        Ok(())
    }
}

/// The cost of reaching equilibrium `signs` with a chain of scene `G`.
#[derive(Debug, Clone)]
pub struct Cost<G: ScalarGeometry> {
    signs: Vec<f64>,
    target: ChartPoint,
    weights: CostWeights,
    /// `sqrt` of the running state weights, per residual entry.
    roots: Vec<f64>,
    track_root: f64,
    track_start: f64,
    /// `L^T` with `P = L L^T` the target's Riccati solution in the chart.
    lt: DMatrix<f64>,
    /// `P` itself.
    p: DMatrix<f64>,
    dt: f64,
    _g: std::marker::PhantomData<G>,
}

/// The paper's linearisation (Prop. 2) at equilibrium `signs` as `(A, B)` in the chart
/// of scene `G`: the spatial local coordinates `[x, C^T xi_i, xdot, C^T w_i]` are the
/// spatial chart there, and they hold the planar chart `[x, angle_i, xdot, w_i]` as the
/// entries `(x.1, xi_i.2, xdot.1, w_i.2)`.
pub fn chart_state_space<G: ScalarGeometry>(
    chain: &Chain<G>,
    signs: &[f64],
) -> Result<(DMatrix<f64>, DMatrix<f64>)> {
    let n = chain.n_links();
    let ss = Linearization::new(chain.params(), signs)?.state_space()?;
    let chart = ChartLayout::of::<G>(n);
    let spatial = ChartLayout::of::<crate::geometry::Spatial>(n);
    let pick = |k: usize| -> usize {
        if G::TANGENT == 2 {
            k
        } else if k == chart.x() {
            spatial.x()
        } else if k < chart.xdot() {
            spatial.tilt(k - chart.tilt(0)) + 1
        } else if k == chart.xdot() {
            spatial.xdot()
        } else {
            spatial.spin(k - chart.spin(0)) + 1
        }
    };
    let nz = chart.dim();
    Ok((
        DMatrix::from_fn(nz, nz, |r, c| ss.a[(pick(r), pick(c))]),
        DMatrix::from_fn(nz, G::CART, |r, c| ss.b[(pick(r), c)]),
    ))
}

/// The running state weights as a diagonal matrix in the chart (`|q - s e3|^2` is the
/// squared tilt to second order).
pub fn diagonal_weights<G: ScalarGeometry>(n: usize, w: &CostWeights) -> DMatrix<f64> {
    let chart = ChartLayout::of::<G>(n);
    let mut q = DMatrix::zeros(chart.dim(), chart.dim());
    for c in 0..G::CART {
        q[(chart.x() + c, chart.x() + c)] = w.x;
        q[(chart.xdot() + c, chart.xdot() + c)] = w.v;
    }
    for i in 0..n {
        for k in 0..G::TANGENT {
            q[(chart.tilt(i) + k, chart.tilt(i) + k)] = w.q;
            q[(chart.spin(i) + k, chart.spin(i) + k)] = w.w;
        }
    }
    q
}

/// The target's LQR in the chart for the running weights (`Q` of
/// [`diagonal_weights`], `R = w_u I`): the Riccati solution `P` (the continuous-time
/// cost-to-go `z^T P z / 2`) and the gain `K = R^-1 B^T P`.
pub fn target_lqr<G: ScalarGeometry>(
    chain: &Chain<G>,
    signs: &[f64],
    weights: &CostWeights,
) -> Result<(DMatrix<f64>, DMatrix<f64>)> {
    let (a, b) = chart_state_space(chain, signs)?;
    let q = diagonal_weights::<G>(chain.n_links(), weights);
    let r = DMatrix::identity(G::CART, G::CART) * weights.force;
    let care = solve_care(&a, &b, &q, &r)?;
    Ok((care.x, care.gain))
}

impl<G: ScalarGeometry> Cost<G> {
    /// The cost of reaching `signs` (checked) for `chain` with control period `dt`, the
    /// track limit `track_limit` and `weights` (checked).
    pub fn new(
        chain: &Chain<G>,
        signs: &[f64],
        weights: CostWeights,
        dt: f64,
        track_limit: f64,
    ) -> Result<Self> {
        weights.validate()?;
        check_positive("track_limit", track_limit)?;
        let n = chain.n_links();
        let target = ChartPoint::new::<G>(n, &chain.equilibrium(signs)?);
        let (p, _) = target_lqr(chain, signs, &weights)?;
        let nz = p.nrows();
        // P is positive definite at every equilibrium (controllable, Q > 0); a tiny
        // shift guards the factorisation against round-off.
        let shifted = &p + DMatrix::identity(nz, nz) * (1e-12 * p.amax());
        let l = Cholesky::new(shifted)
            .ok_or_else(|| ChainError::Analysis {
                reason: "the target's Riccati solution is not positive definite".into(),
            })?
            .l();
        let mut roots = Vec::new();
        roots.extend(std::iter::repeat_n(weights.x.sqrt(), G::CART));
        roots.extend(std::iter::repeat_n(weights.q.sqrt(), n * G::LINK));
        roots.extend(std::iter::repeat_n(weights.v.sqrt(), G::CART));
        roots.extend(std::iter::repeat_n(weights.w.sqrt(), n * G::SPIN));
        Ok(Self {
            signs: signs.to_vec(),
            target,
            weights,
            roots,
            track_root: weights.track.sqrt(),
            track_start: weights.track_margin * track_limit,
            lt: l.transpose(),
            p,
            dt,
            _g: std::marker::PhantomData,
        })
    }

    /// The target's sign tuple.
    pub fn signs(&self) -> &[f64] {
        &self.signs
    }
    /// The target equilibrium's chart.
    pub fn target(&self) -> &ChartPoint {
        &self.target
    }
    /// The weights.
    pub fn weights(&self) -> &CostWeights {
        &self.weights
    }
    /// The target's Riccati solution in the chart.
    pub fn riccati(&self) -> &DMatrix<f64> {
        &self.p
    }
    /// Control period, s.
    pub fn dt(&self) -> f64 {
        self.dt
    }
    /// Entries of the running state residual.
    pub fn running_len(&self) -> usize {
        self.roots.len() + G::CART
    }
    /// Entries of the terminal residual.
    pub fn terminal_len(&self) -> usize {
        self.roots.len() + self.lt.nrows()
    }

    /// The running state residual (without the `dt` factor).
    pub fn running_residual<S: Real>(&self, y: &[S], r: &mut [S]) {
        let m = self.state_residual(y, r, 1.0);
        let lay = Layout::<G>::new(self.signs.len());
        for c in 0..G::CART {
            let x = y[lay.x() + c];
            let excess = x.re().abs() - self.track_start;
            r[m + c] = if excess > 0.0 {
                let signed = if x.re() > 0.0 {
                    x + (-self.track_start)
                } else {
                    -x + (-self.track_start)
                };
                signed * self.track_root
            } else {
                S::cst(0.0)
            };
        }
    }

    /// The terminal residual; `z` is scratch of the chart's size.
    pub fn terminal_residual<S: Real>(&self, y: &[S], r: &mut [S], z: &mut [S]) {
        let m = self.state_residual(y, r, self.weights.terminal.sqrt());
        local::<G, S>(&self.target, y, z);
        let nz = z.len();
        for row in 0..nz {
            let mut acc = S::cst(0.0);
            for (col, zc) in z.iter().enumerate().skip(row) {
                acc += *zc * self.lt[(row, col)];
            }
            r[m + row] = acc;
        }
    }

    /// The weighted distance residual `[x, q_i - s_i e3, xdot, w_i]`, times `scale`;
    /// returns its length.
    fn state_residual<S: Real>(&self, y: &[S], r: &mut [S], scale: f64) -> usize {
        let lay = Layout::<G>::new(self.signs.len());
        let mut k = 0;
        let mut push = |v: S, r: &mut [S]| {
            r[k] = v * (self.roots[k] * scale);
            k += 1;
        };
        for c in 0..G::CART {
            push(y[lay.x() + c], r);
        }
        for (i, &s) in self.signs.iter().enumerate() {
            let down = G::down_unit_s::<f64>();
            let mut e = [0.0; 3];
            down.store(&mut e);
            for c in 0..G::LINK {
                push(y[lay.q(i) + c] + (-s * e[c]), r);
            }
        }
        for c in 0..G::CART {
            push(y[lay.xdot() + c], r);
        }
        for i in 0..self.signs.len() {
            for c in 0..G::SPIN {
                push(y[lay.w(i) + c], r);
            }
        }
        k
    }

    /// The running cost of state residual `r` and force `u`: `dt (|r|^2 + w_u |u|^2) / 2`.
    pub fn running_cost(&self, r: &[f64], u: &[f64]) -> f64 {
        let rr: f64 = r.iter().map(|v| v * v).sum();
        let uu: f64 = u.iter().map(|v| v * v).sum();
        0.5 * self.dt * (rr + self.weights.force * uu)
    }
}

#[cfg(test)]
mod tests {
    use super::CostWeights;

    #[test]
    fn each_weight_is_set_and_read_under_its_own_name() {
        for (i, name) in CostWeights::NAMES.iter().enumerate() {
            let mut w = CostWeights::default();
            *w.by_name_mut(name).unwrap() = 100.0 + i as f64;
            let named = w.named();
            let defaults = CostWeights::default().named();
            for (j, (other, value)) in named.iter().enumerate() {
                assert_eq!(other, &CostWeights::NAMES[j]);
                let expected = if j == i {
                    100.0 + i as f64
                } else {
                    defaults[j].1
                };
                assert_eq!(*value, expected, "{name} set, {other} read");
            }
        }
        assert_eq!(CostWeights::default().named()[1], ("q", 10.0));
        assert!(CostWeights::default().by_name_mut("qq").is_none());
    }
}
