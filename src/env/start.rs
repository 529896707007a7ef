//! Start states: the base state of a [`Start`] and the uniform noise around it.
//!
//! **Noise.** With half-width `a`, a reset draws, in this order, from the env's own
//! ChaCha8 stream (`u = a (2 r - 1)`, `r` uniform in `[0, 1)`, so `u` in `[-a, a)`):
//!
//! 1. the cart position offset (2 numbers spatial, 1 planar): `x += u`;
//! 2. the cart velocity offset (likewise): `xdot += u`;
//! 3. for each link i = 1..n, a tilt about the horizontal axes, the rotation vector
//!    `theta_i = (u, u, 0)` (planar: the angle `u` about e2): `q_i <- exp(theta_i^) q_i`,
//!    which keeps `|q_i| = 1` exactly;
//! 4. for each link, a horizontal spin `d_i = (u, u, 0)` (planar: `u e2`):
//!    `w_i <- w_i + d_i` minus its component along the tilted `q_i`, which keeps
//!    `w_i . q_i = 0` (at a vertical base link the removed part is second order).
//!
//! `a = 0` returns the base state exactly.

use super::config::{check_paper_links, PaperFigure, Start, TaskConfig};
use crate::error::{check_finite, check_len, InputError, Result};
use crate::geometry::{spatial_to_planar, Geometry, Layout, Spatial, Vector};
use crate::model::Chain;
use nalgebra::{Vector2, Vector3};
use rand::Rng;

/// Largest `| |q_i| - 1 |` or `|w_i . q_i|` accepted in an explicit start state.
pub const START_STATE_TOLERANCE: f64 = 1e-9;

/// The paper's initial condition for `fig` in the spatial layout (n = 5):
/// IC1 (Figs. 1 and 2) `x = (0.2, 0.1)`, `xdot = (0, -0.1)`, `q_i = (-1)^i e3` for
/// i = 1..4, `q_5 = (sin 1deg, 0, -cos 1deg)`, `w_i = 0`; Fig. 3 the same `x`, `xdot`,
/// `w` with `q_1 = -(sin 6deg, 0, cos 6deg)`, `q_2 = q_3 = -(0, sin 4deg, cos 4deg)`
/// (the paper's four-entry vector read as three, see docs/physics.md), `q_4 = (sin 5deg cos 4deg,
/// -sin 5deg sin 4deg, cos 5deg)`, `q_5 = (-sin 35deg, 0, cos 35deg)`.
pub fn paper_initial_condition(fig: PaperFigure) -> Vec<f64> {
    let n = 5;
    let lay = Layout::<Spatial>::new(n);
    let mut y = vec![0.0; lay.dim()];
    lay.store_x(&mut y, Vector2::new(0.2, 0.1));
    lay.store_xdot(&mut y, Vector2::new(0.0, -0.1));
    let deg = |d: f64| d.to_radians();
    let q: [Vector3<f64>; 5] = match fig {
        PaperFigure::Fig1 | PaperFigure::Fig2 => {
            let mut q = [Vector3::zeros(); 5];
            for (i, qi) in q.iter_mut().enumerate().take(4) {
                // (-1)^i with the paper's 1-based i.
                *qi = Vector3::new(0.0, 0.0, if i % 2 == 0 { -1.0 } else { 1.0 });
            }
            q[4] = Vector3::new(deg(1.0).sin(), 0.0, -deg(1.0).cos());
            q
        }
        PaperFigure::Fig3 => {
            let q23 = -Vector3::new(0.0, deg(4.0).sin(), deg(4.0).cos());
            [
                -Vector3::new(deg(6.0).sin(), 0.0, deg(6.0).cos()),
                q23,
                q23,
                Vector3::new(
                    deg(5.0).sin() * deg(4.0).cos(),
                    -deg(5.0).sin() * deg(4.0).sin(),
                    deg(5.0).cos(),
                ),
                Vector3::new(-deg(35.0).sin(), 0.0, deg(35.0).cos()),
            ]
        }
    };
    for (i, qi) in q.iter().enumerate() {
        lay.store_q(&mut y, i, *qi);
    }
    y
}

/// The state episodes start from before noise, in the chain's own layout. A planar
/// chain takes the in-plane part of a paper initial condition (IC1's out-of-plane
/// cart drift is decoupled from the rest); Fig. 3 leaves the plane and is refused.
pub fn base_state<G: Geometry>(chain: &Chain<G>, task: &TaskConfig) -> Result<Vec<f64>> {
    let n = chain.n_links();
    match &task.start {
        Start::Target => chain.equilibrium(&task.target),
        Start::Equilibrium(s) => chain.equilibrium(s),
        Start::Paper(fig) => {
            check_paper_links(*fig, n)?;
            let spatial = paper_initial_condition(*fig);
            if G::Link::DIM == 3 {
                return Ok(spatial);
            }
            if *fig == PaperFigure::Fig3 {
                return Err(InputError::InvalidParameter {
                    name: "planar",
                    value: 1.0,
                    expected: "False for start \"paper-fig3\" (its links leave the e1-e3 plane)",
                }
                .into());
            }
            let mut planar = vec![0.0; chain.state_dim()];
            spatial_to_planar(n, &spatial, &mut planar);
            Ok(planar)
        }
        Start::State(y) => {
            check_len("start", y, chain.state_dim())?;
            check_finite("start", y)?;
            let r = chain.residuals(y);
            if r.unit_length > START_STATE_TOLERANCE {
                return Err(InputError::InvalidParameter {
                    name: "start state's max | |q_i| - 1 |",
                    value: r.unit_length,
                    expected: "at most 1e-9 (link directions are unit vectors)",
                }
                .into());
            }
            if r.tangency > START_STATE_TOLERANCE {
                return Err(InputError::InvalidParameter {
                    name: "start state's max |w_i . q_i|",
                    value: r.tangency,
                    expected: "at most 1e-9 (angular velocities are normal to their links)",
                }
                .into());
            }
            Ok(y.clone())
        }
    }
}

#[inline(always)]
fn draw<R: Rng>(rng: &mut R, half_width: f64) -> f64 {
    half_width * (2.0 * rng.random::<f64>() - 1.0)
}

/// A horizontal vector of `G::Cart::DIM` uniform draws, read as a value of type `V`
/// (cart vector, or a spin/rotation vector with zero vertical part).
#[inline(always)]
fn horizontal<G: Geometry, V: Vector, R: Rng>(rng: &mut R, half_width: f64) -> V {
    let mut buf = [0.0; 3];
    for b in buf.iter_mut().take(G::Cart::DIM) {
        *b = draw(rng, half_width);
    }
    V::load(&buf)
}

/// Writes `base` plus the documented noise into `y` (no allocation).
pub fn perturb<G: Geometry, R: Rng>(
    layout: Layout<G>,
    base: &[f64],
    half_width: f64,
    rng: &mut R,
    y: &mut [f64],
) {
    y.copy_from_slice(base);
    let dx: G::Cart = horizontal::<G, _, _>(rng, half_width);
    layout.store_x(y, layout.load_x(y) + dx);
    let dv: G::Cart = horizontal::<G, _, _>(rng, half_width);
    layout.store_xdot(y, layout.load_xdot(y) + dv);
    for i in 0..layout.n {
        let theta: G::Spin = horizontal::<G, _, _>(rng, half_width);
        layout.store_q(y, i, G::rotate(theta, layout.load_q(y, i)));
    }
    for i in 0..layout.n {
        let d: G::Spin = horizontal::<G, _, _>(rng, half_width);
        let q = layout.load_q(y, i);
        layout.store_w(y, i, G::tangent(layout.load_w(y, i) + d, q));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Planar;
    use crate::integrate::StepOptions;
    use crate::params::ChainParams;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    fn task(start: Start) -> TaskConfig {
        let mut t = TaskConfig::new(vec![-1.0; 5], 0.01, StepOptions::default());
        t.start = start;
        t
    }

    #[test]
    fn paper_initial_conditions_are_on_the_constraint_manifold() {
        let chain = Chain::<Spatial>::new(ChainParams::paper());
        for fig in [PaperFigure::Fig1, PaperFigure::Fig3] {
            let y = paper_initial_condition(fig);
            let r = chain.residuals(&y);
            assert!(r.unit_length < 1e-15 && r.tangency == 0.0, "{fig:?}: {r:?}");
        }
        // IC1 is the folded equilibrium s = (-1, 1, -1, 1, -1) with the last link tilted 1 degree.
        let y = paper_initial_condition(PaperFigure::Fig1);
        let (e_q, e_w) = chain.errors(&y, &PaperFigure::Fig1.target());
        let tilt = 2.0 * (0.5f64.to_radians()).sin(); // chord of a 1 degree arc
        assert!((e_q - tilt).abs() < 1e-15 && e_w == 0.0, "{e_q}");
        assert_eq!(&y[..4], &[0.2, 0.1, 0.0, -0.1]);
    }

    #[test]
    fn planar_chains_take_the_in_plane_part_and_refuse_fig3() {
        let chain = Chain::<Planar>::new(ChainParams::paper());
        let y = base_state(&chain, &task(Start::Paper(PaperFigure::Fig2))).unwrap();
        assert_eq!(y.len(), 2 + 3 * 5);
        assert_eq!(&y[..2], &[0.2, 0.0]);
        assert_eq!(y[2 + 2 * 4], 1f64.to_radians().sin());
        let e = base_state(&chain, &task(Start::Paper(PaperFigure::Fig3))).unwrap_err();
        assert!(e.to_string().contains("paper-fig3"), "{e}");
    }

    #[test]
    fn explicit_start_states_are_checked() {
        let chain = Chain::<Planar>::new(ChainParams::uniform(1, 1.0, 0.1, 0.5, 9.81).unwrap());
        let ok = vec![0.1, 0.0, 0.6, -0.8, 0.3];
        assert_eq!(
            base_state(&chain, &task(Start::State(ok.clone()))).unwrap(),
            ok
        );
        let e = base_state(&chain, &task(Start::State(vec![0.0, 0.0, 0.6, 0.6, 0.0])))
            .unwrap_err()
            .to_string();
        assert!(e.contains("|q_i|"), "{e}");
        assert!(base_state(&chain, &task(Start::State(vec![0.0; 4]))).is_err());
    }

    fn noise_stays_on_the_manifold_and_in_bounds<G: Geometry>() {
        let chain = Chain::<G>::new(ChainParams::uniform(3, 1.0, 0.1, 0.5, 9.81).unwrap());
        let lay = chain.layout();
        let base = chain.equilibrium(&[-1.0, 1.0, -1.0]).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut y = vec![0.0; chain.state_dim()];
        let a = 0.2;
        let mut largest = 0.0f64;
        for _ in 0..200 {
            perturb(lay, &base, a, &mut rng, &mut y);
            let r = chain.residuals(&y);
            assert!(r.unit_length < 1e-15 && r.tangency < 1e-15, "{r:?}");
            // Cart coordinates and spins move by at most a; each link tilts by at most
            // |theta| <= a sqrt(2) (spatial) or a (planar).
            for k in 0..2 * G::Cart::DIM {
                assert!((y[k] - base[k]).abs() <= a);
                largest = largest.max((y[k] - base[k]).abs());
            }
            for i in 0..3 {
                let (q, q0) = (lay.load_q(&y, i), lay.load_q(&base, i));
                let angle = 2.0 * ((q - q0).norm_squared().sqrt() / 2.0).asin();
                assert!(angle <= a * 2f64.sqrt() + 1e-12, "{angle}");
                assert!(lay.load_w(&y, i).norm_squared().sqrt() <= a * 2f64.sqrt() + 1e-12);
            }
        }
        // The draws fill the interval rather than collapsing to the base state.
        assert!(largest > 0.9 * a, "{largest}");
        // Zero noise is the base state, bit for bit.
        perturb(lay, &base, 0.0, &mut rng, &mut y);
        assert_eq!(y, base);
    }

    #[test]
    fn noise_keeps_constraints_spatial() {
        noise_stays_on_the_manifold_and_in_bounds::<Spatial>();
    }

    #[test]
    fn noise_keeps_constraints_planar() {
        noise_stays_on_the_manifold_and_in_bounds::<Planar>();
    }

    #[test]
    fn the_same_seed_gives_the_same_start() {
        let chain = Chain::<Spatial>::new(ChainParams::uniform(2, 1.0, 0.1, 0.5, 9.81).unwrap());
        let base = chain.equilibrium(&[-1.0, -1.0]).unwrap();
        let mut a = vec![0.0; chain.state_dim()];
        let mut b = a.clone();
        perturb(
            chain.layout(),
            &base,
            0.1,
            &mut ChaCha8Rng::seed_from_u64(3),
            &mut a,
        );
        perturb(
            chain.layout(),
            &base,
            0.1,
            &mut ChaCha8Rng::seed_from_u64(3),
            &mut b,
        );
        assert_eq!(a, b);
        perturb(
            chain.layout(),
            &base,
            0.1,
            &mut ChaCha8Rng::seed_from_u64(4),
            &mut b,
        );
        assert_ne!(a, b);
    }
}
