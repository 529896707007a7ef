//! The paper's analysis against the nonlinear model: Prop. 2 versus finite differences,
//! the eigenstructure of the 2^n equilibria, Prop. 3, the Riccati solver and the LQR gains.

use chaincart::analysis::spectral_abscissa;
use chaincart::analysis::{
    all_signs, controllability, equilibria, solve_care, Linearization, LocalLayout, LqrController,
    LqrWeights,
};
use chaincart::analysis::{
    controllability_with_rig, pbh_margin, pbh_margin_damped, CONTROLLABILITY_THRESHOLD,
};
use chaincart::analysis::{local_coordinates, local_rates, state_from_local};
use chaincart::analysis::{lowest, named_signs, signs_of_index};
use chaincart::params::{Actuation, Motor, Rig};
use chaincart::{ChainError, ChainParams, InputError, SpatialChain};
use nalgebra::{DMatrix, DVector, Vector2};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

fn log_uniform(rng: &mut StdRng, lo: f64, hi: f64) -> f64 {
    rng.random_range(lo.ln()..hi.ln()).exp()
}

/// Masses in [0.05, 0.05 ratio], lengths in [0.1, 0.1 ratio], cart in [0.1, 10].
fn random_params(rng: &mut StdRng, n: usize, ratio: f64) -> ChainParams {
    let masses: Vec<f64> = (0..n)
        .map(|_| log_uniform(rng, 0.05, 0.05 * ratio))
        .collect();
    let lengths: Vec<f64> = (0..n).map(|_| log_uniform(rng, 0.1, 0.1 * ratio)).collect();
    ChainParams::new(log_uniform(rng, 0.1, 10.0), &masses, &lengths, 9.81).unwrap()
}

fn random_signs(rng: &mut StdRng, n: usize) -> Vec<f64> {
    (0..n)
        .map(|_| if rng.random_bool(0.5) { 1.0 } else { -1.0 })
        .collect()
}

/// `zdot` of the nonlinear model at the state with local coordinates `z` and force `u`.
fn nonlinear_rates(chain: &SpatialChain, s: &[f64], z: &[f64], u: Vector2<f64>) -> DVector<f64> {
    let mut y = vec![0.0; chain.state_dim()];
    state_from_local(s, z, &mut y).unwrap();
    let mut dy = vec![0.0; chain.state_dim()];
    chain.derivative(&y, u, &mut chain.workspace(), &mut dy);
    let mut zdot = vec![0.0; z.len()];
    local_rates(s, &y, &dy, &mut zdot).unwrap();
    DVector::from_vec(zdot)
}

/// Central-difference Jacobians `(A, B)` of the nonlinear model in the local coordinates.
fn finite_difference_linearisation(
    chain: &SpatialChain,
    s: &[f64],
    eps: f64,
) -> (DMatrix<f64>, DMatrix<f64>) {
    let dim = LocalLayout::new(s.len()).dim();
    let mut a = DMatrix::zeros(dim, dim);
    for k in 0..dim {
        let mut zp = vec![0.0; dim];
        let mut zm = vec![0.0; dim];
        zp[k] = eps;
        zm[k] = -eps;
        let col = (nonlinear_rates(chain, s, &zp, Vector2::zeros())
            - nonlinear_rates(chain, s, &zm, Vector2::zeros()))
            / (2.0 * eps);
        a.set_column(k, &col);
    }
    let mut b = DMatrix::zeros(dim, 2);
    let zero = vec![0.0; dim];
    for k in 0..2 {
        let mut du = Vector2::zeros();
        du[k] = eps;
        let col = (nonlinear_rates(chain, s, &zero, du) - nonlinear_rates(chain, s, &zero, -du))
            / (2.0 * eps);
        b.set_column(k, &col);
    }
    (a, b)
}

fn relative_error(approx: &DMatrix<f64>, exact: &DMatrix<f64>) -> f64 {
    (approx - exact).amax() / exact.amax()
}

#[test]
fn prop2_matches_finite_differences_of_the_nonlinear_model() {
    let mut rng = StdRng::seed_from_u64(7);
    let mut worst: f64 = 0.0;
    for n in 1..=6 {
        for trial in 0..2 {
            let params = if n == 5 && trial == 0 {
                ChainParams::paper()
            } else {
                random_params(&mut rng, n, 10.0)
            };
            let chain = SpatialChain::new(params.clone());
            let mut cases: Vec<Vec<f64>> = ["hanging", "inverted", "folded", "folded_up"]
                .iter()
                .map(|name| named_signs(name, n).unwrap())
                .collect();
            cases.push(random_signs(&mut rng, n));
            for s in cases {
                let lin = Linearization::new(&params, &s).unwrap();
                let ss = lin.state_space().unwrap();
                let (a_fd, b_fd) = finite_difference_linearisation(&chain, &s, 1e-6);
                let (ea, eb) = (relative_error(&a_fd, &ss.a), relative_error(&b_fd, &ss.b));
                assert!(ea < 1e-6 && eb < 1e-6, "n {n} s {s:?}: A {ea:e}, B {eb:e}");
                worst = worst.max(ea).max(eb);
            }
        }
    }
    println!("worst relative FD error of (A, B): {worst:e}");
}

/// The rigs the rig linearisation is checked with, for `n` links: joint damping alone,
/// cart friction (viscous and Coulomb), a DC motor on a rough cart, a servo axis.
fn test_rigs(n: usize) -> Vec<Rig> {
    let damping: Vec<f64> = (0..n).map(|i| 0.02 + 0.01 * i as f64).collect();
    let motor = Motor::from_array(chaincart::env::DEFAULT_MOTOR);
    vec![
        Rig {
            joint_damping: damping.clone(),
            ..Rig::default()
        },
        Rig {
            cart_viscous_friction: 0.7,
            cart_coulomb_friction: 0.4,
            coulomb_velocity: 0.05,
            ..Rig::default()
        },
        Rig {
            joint_damping: vec![0.03],
            cart_viscous_friction: 0.2,
            cart_coulomb_friction: 0.3,
            coulomb_velocity: 0.1,
            actuation: Actuation::Voltage(motor),
        },
        Rig {
            joint_damping: damping,
            actuation: Actuation::Acceleration,
            ..Rig::default()
        },
    ]
}

#[test]
fn rig_linearisation_matches_finite_differences_of_the_rig_dynamics() {
    let mut rng = StdRng::seed_from_u64(11);
    let mut worst: f64 = 0.0;
    for n in 1..=4 {
        let params = random_params(&mut rng, n, 10.0);
        let mut cases: Vec<Vec<f64>> = ["hanging", "inverted"]
            .iter()
            .map(|name| named_signs(name, n).unwrap())
            .collect();
        cases.push(random_signs(&mut rng, n));
        for rig in test_rigs(n) {
            let chain = SpatialChain::new(params.clone())
                .with_rig(rig.clone())
                .unwrap();
            for s in &cases {
                let lin = Linearization::with_rig(&params, s, &rig).unwrap();
                let ss = lin.state_space().unwrap();
                let (a_fd, b_fd) = finite_difference_linearisation(&chain, s, 1e-6);
                let (ea, eb) = (relative_error(&a_fd, &ss.a), relative_error(&b_fd, &ss.b));
                let mode = rig.actuation.name();
                assert!(
                    ea < 1e-6 && eb < 1e-6,
                    "n {n} s {s:?} {mode}: A {ea:e}, B {eb:e}"
                );
                worst = worst.max(ea).max(eb);
                // The rig changes the model: the ideal linearisation is not the oracle's.
                let ideal = Linearization::new(&params, s)
                    .unwrap()
                    .state_space()
                    .unwrap();
                assert!(
                    relative_error(&a_fd, &ideal.a).max(relative_error(&b_fd, &ideal.b)) > 1e-4
                );
            }
        }
    }
    println!("worst relative FD error of the rig's (A, B): {worst:e}");
}

#[test]
fn acceleration_input_is_the_force_input_through_the_cart_row() {
    // With the cart prescribed, the chain rows read M_qq pdd + G_qq p = -M_qx a; the
    // force-mode linearisation gives the same rows once u is chosen so that xdd = a.
    let params = ChainParams::paper();
    let s = named_signs("inverted", 5).unwrap();
    let servo = Rig {
        actuation: Actuation::Acceleration,
        ..Rig::default()
    };
    let acc = Linearization::with_rig(&params, &s, &servo)
        .unwrap()
        .state_space()
        .unwrap();
    let force = Linearization::new(&params, &s)
        .unwrap()
        .state_space()
        .unwrap();
    let dim = LocalLayout::new(5).dim();
    let half = dim / 2;
    // In force mode xdd = A_x z + B_x u; u = B_x^-1 (a - A_x z) gives xdd = a.
    let b_x = force.b.view((half, 0), (2, 2)).into_owned();
    let b_x_inv = b_x.try_inverse().unwrap();
    let a_x = force.a.view((half, 0), (2, dim)).into_owned();
    let a_via_force = &force.a - &force.b * &b_x_inv * &a_x;
    let b_via_force = &force.b * &b_x_inv;
    assert!(relative_error(&acc.a, &a_via_force) < 1e-10);
    assert!(relative_error(&acc.b, &b_via_force) < 1e-10);
    let lqr = LqrController::with_rig(&params, &s, &servo, &LqrWeights::paper_default(&s)).unwrap();
    let closed = &acc.a - &acc.b * lqr.gain();
    assert!(spectral_abscissa(&closed) < 0.0);
}

#[test]
fn the_damped_test_without_damping_is_prop_3_and_damping_moves_the_margin_continuously() {
    let params = ChainParams::paper();
    for s in all_signs(5).unwrap() {
        let lin = Linearization::new(&params, &s).unwrap();
        let zero = DMatrix::zeros(10, 10);
        let undamped = controllability(&params, &s).unwrap();
        let quadratic = pbh_margin_damped(&lin.m_qq(), &zero, &lin.g_qq(), &lin.m_qx()).unwrap();
        assert!(quadratic.controllable, "{s:?}");
        let relative = (quadratic.margin - undamped.margin).abs() / undamped.margin;
        assert!(relative < 1e-6, "{s:?}: {quadratic:?} against {undamped:?}");
        // A little joint damping moves the margin a little and keeps the verdict.
        let rig = Rig {
            joint_damping: vec![1e-5],
            ..Rig::default()
        };
        let damped = controllability_with_rig(&params, &s, &rig).unwrap();
        assert!(damped.controllable, "{s:?}");
        assert!(
            (damped.margin - undamped.margin).abs() < 0.05 * undamped.margin,
            "{s:?}: {damped:?}"
        );
    }
}

#[test]
fn cart_friction_and_the_actuation_leave_the_verdict_as_prop_3_gives_it() {
    let params = ChainParams::uniform(3, 1.0, 0.1, 0.5, 9.81).unwrap();
    let s = named_signs("inverted", 3).unwrap();
    let ideal = controllability(&params, &s).unwrap();
    for rig in [
        Rig {
            cart_viscous_friction: 2.0,
            cart_coulomb_friction: 0.5,
            ..Rig::default()
        },
        Rig {
            actuation: Actuation::Acceleration,
            ..Rig::default()
        },
    ] {
        assert_eq!(controllability_with_rig(&params, &s, &rig).unwrap(), ideal);
    }
    let damped = Rig {
        joint_damping: vec![0.02, 0.01, 0.005],
        ..Rig::default()
    };
    let c = controllability_with_rig(&params, &s, &damped).unwrap();
    assert!(c.controllable && c.weakest_multiplicity == 2, "{c:?}");
}

/// The first-order PBH test on `(A, B)`: `min over eigenvalues lambda of A` of the
/// smallest singular value of `[A - lambda I, B]`, relative to `||[A, B]||`.
fn first_order_pbh(lin: &Linearization) -> f64 {
    use nalgebra::Complex;
    let ss = lin.state_space().unwrap();
    let (dim, inputs) = (ss.a.nrows(), ss.b.ncols());
    let mut ab = DMatrix::zeros(dim, dim + inputs);
    ab.view_mut((0, 0), (dim, dim)).copy_from(&ss.a);
    ab.view_mut((0, dim), (dim, inputs)).copy_from(&ss.b);
    let scale = ab.clone().svd(false, false).singular_values.max();
    let ab = ab.map(|x| Complex::new(x, 0.0));
    ss.a.complex_eigenvalues()
        .iter()
        .map(|&lambda| {
            let mut shifted = ab.clone();
            for i in 0..dim {
                shifted[(i, i)] -= lambda;
            }
            shifted.svd(false, false).singular_values.min() / scale
        })
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn the_rig_verdicts_agree_with_the_first_order_pbh_test() {
    let params = ChainParams::uniform(2, 1.0, 0.1, 0.5, 9.81).unwrap();
    let motor = Motor {
        torque_constant: 0.02,
        resistance: 2.0,
        gear_ratio: 5.0,
        pulley_radius: 0.02,
        current_limit: 5.0,
    };
    for s in all_signs(2).unwrap() {
        for actuation in [
            Actuation::Force,
            Actuation::Acceleration,
            Actuation::Voltage(motor),
        ] {
            // A servo axis takes no cart friction (it tracks its acceleration anyway).
            let friction = if actuation == Actuation::Acceleration {
                0.0
            } else {
                1.0
            };
            let rig = Rig {
                joint_damping: vec![0.02, 0.005],
                cart_viscous_friction: friction,
                actuation,
                ..Rig::default()
            };
            let verdict = controllability_with_rig(&params, &s, &rig).unwrap();
            let lin = Linearization::with_rig(&params, &s, &rig).unwrap();
            let pbh = first_order_pbh(&lin);
            assert!(
                verdict.controllable && pbh > 1e-9,
                "{s:?} {actuation:?}: {verdict:?}, {pbh}"
            );
        }
    }
}

#[test]
fn the_lqr_designs_without_the_coulomb_term_that_the_linearisation_keeps() {
    // The Coulomb law's slope at rest is the exact first order (the linearisation keeps
    // it), but a gain designed for it expects damping the cart has only below v_eps.
    let params = ChainParams::uniform(2, 1.0, 0.1, 0.5, 9.81).unwrap();
    let s = named_signs("inverted", 2).unwrap();
    let weights = LqrWeights::paper_default(&s);
    let rig = Rig {
        joint_damping: vec![0.01],
        cart_viscous_friction: 0.3,
        cart_coulomb_friction: 1.0,
        ..Rig::default()
    };
    let smooth = rig.without_coulomb_friction();
    assert_eq!(smooth.cart_coulomb_friction, 0.0);
    assert_eq!(smooth.cart_viscous_friction, 0.3);
    let with = Linearization::with_rig(&params, &s, &rig)
        .unwrap()
        .state_space()
        .unwrap();
    let without = Linearization::with_rig(&params, &s, &smooth)
        .unwrap()
        .state_space()
        .unwrap();
    assert!(relative_error(&with.a, &without.a) > 1e-3);
    let designed = LqrController::with_rig(&params, &s, &rig, &weights).unwrap();
    let smooth_design = LqrController::with_rig(&params, &s, &smooth, &weights).unwrap();
    assert_eq!(designed.gain(), smooth_design.gain());
    // It still stabilises the smooth part of the rig.
    assert!(spectral_abscissa(&(&without.a - &without.b * designed.gain())) < 0.0);
}

#[test]
fn second_order_form_is_symmetric_and_consistent() {
    let params = ChainParams::paper();
    for s in all_signs(5).unwrap() {
        let lin = Linearization::new(&params, &s).unwrap();
        let m = lin.mass_matrix();
        assert_eq!(m, &m.transpose());
        assert!(m.clone().cholesky().is_some(), "M must be SPD at {s:?}");
        // M_qx is the paper's -s_i M_0i e3^ C, transposed: block i = s_i M_0i E.
        let m_qx = lin.m_qx();
        for (i, &si) in s.iter().enumerate() {
            let c = si * params.cart_coupling(i);
            let block = m_qx.view((2 * i, 0), (2, 2));
            assert_eq!(block[(0, 1)], -c);
            assert_eq!(block[(1, 0)], c);
        }
    }
}

#[test]
fn eigenstructure_of_the_32_paper_equilibria() {
    let params = ChainParams::paper();
    for s in all_signs(5).unwrap() {
        let lin = Linearization::new(&params, &s).unwrap();
        let eig = lin.eigenvalues().unwrap();
        assert_eq!(eig.len(), 24);
        let zeros = eig.iter().filter(|l| l.norm() == 0.0).count();
        let positive_real = eig.iter().filter(|l| l.re > 0.0 && l.im == 0.0).count();
        let upright = s.iter().filter(|&&v| v < 0.0).count();
        assert_eq!(zeros, 4, "the cart's double integrators, s = {s:?}");
        // Sylvester's law of inertia: G_qq has 2 * upright negative entries, so the
        // pencil has as many negative mu, each giving a +-sqrt(-mu) saddle pair.
        assert_eq!(positive_real, 2 * upright, "s = {s:?}");
        if upright == 0 {
            assert!(eig.iter().all(|l| l.re == 0.0), "hanging: {eig:?}");
        }
        // Cross-check with a general eigen-solver on A (which splits the cart's Jordan
        // blocks into tiny pairs, hence the loose absolute tolerance on the zero part).
        let a = lin.state_space().unwrap().a;
        let general_max = spectral_abscissa(&a);
        let ours_max = eig.iter().map(|l| l.re).fold(f64::NEG_INFINITY, f64::max);
        let scale = eig.iter().map(|l| l.norm()).fold(0.0, f64::max);
        assert!(
            (general_max - ours_max).abs() < 1e-6 * scale,
            "{s:?}: {general_max} vs {ours_max}"
        );
    }
}

#[test]
fn equilibria_energies_and_the_minimum() {
    let chain = SpatialChain::new(ChainParams::paper());
    let list = equilibria(&chain).unwrap();
    assert_eq!(list.len(), 32);
    let low = lowest(&list).unwrap();
    assert_eq!(low.index, 0);
    assert_eq!(low.name, Some("hanging"));
    // V = -sum_i s_i g l_i sum_{a>=i} m_a: hanging -0.1 * 9.81 * 0.1 * (5+4+3+2+1).
    assert!((low.energy + 0.1 * 9.81 * 0.1 * 15.0).abs() < 1e-12);
    let top = list
        .iter()
        .max_by(|a, b| a.energy.total_cmp(&b.energy))
        .unwrap();
    assert_eq!(top.name, Some("inverted"));
    assert_eq!(list[21].signs, signs_of_index(21, 5));
    let folded_up = list.iter().find(|e| e.name == Some("folded_up")).unwrap();
    assert_eq!(folded_up.signs, vec![-1.0, 1.0, -1.0, 1.0, -1.0]);
    assert!(matches!(
        LqrController::paper(&ChainParams::paper(), &[1.0, 1.0]),
        Err(ChainError::Input(InputError::LengthMismatch { .. }))
    ));
}

#[test]
fn all_32_paper_equilibria_are_controllable() {
    let params = ChainParams::paper();
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for s in all_signs(5).unwrap() {
        let c = controllability(&params, &s).unwrap();
        assert!(c.controllable, "{s:?}: {c:?}");
        assert_eq!(
            c.weakest_multiplicity, 2,
            "every chain mode is a planar pair"
        );
        lo = lo.min(c.margin);
        hi = hi.max(c.margin);
    }
    println!("paper system: PBH margins over the 32 equilibria in [{lo:.4e}, {hi:.4e}]");
    assert!(lo > 1e-3);
}

/// The Kalman matrix of the paper's system is too badly scaled for a numerical rank test (why the PBH test is used).
#[test]
fn kalman_rank_is_not_used_and_here_is_why() {
    let params = ChainParams::paper();
    let ss = Linearization::new(&params, &[1.0; 5])
        .unwrap()
        .state_space()
        .unwrap();
    let dim = ss.a.nrows();
    let mut kalman = DMatrix::zeros(dim, 2 * dim);
    let mut block = ss.b.clone();
    for k in 0..dim {
        kalman.view_mut((0, 2 * k), (dim, 2)).copy_from(&block);
        block = &ss.a * block;
    }
    let sv = kalman.svd(false, false).singular_values;
    let (hi, lo) = (sv.max(), sv.min());
    let rank = sv.iter().filter(|&&v| v > hi * 1e-12).count();
    println!(
        "hanging, paper system: Kalman matrix singular values from {hi:.1e} down to {lo:.1e}, \
         numerical rank {rank} of {dim} (PBH: controllable)"
    );
    assert!(controllability(&params, &[1.0; 5]).unwrap().controllable);
}

/// Prop. 3's margin from the tridiagonal mass-position form derived in the docs of
/// `analysis::controllability`: with `k_a = s_a g (sum_{b>=a} m_b) / l_a` and the
/// planar modes `K y = mu diag(m) y`, each mode's coupling is `|k_1 y_1 / mu|` over
/// `||theta|| ||c||` (`theta_a = (y_a - y_(a-1)) / (s_a l_a)`, `c_a = M_0a`). An oracle
/// that shares no code with the PBH implementation.
fn tridiagonal_margin(p: &ChainParams, s: &[f64]) -> f64 {
    let n = p.n_links();
    let (m, l, g) = (p.masses(), p.lengths(), p.gravity());
    let k: Vec<f64> = (0..n)
        .map(|a| s[a] * g * p.outboard_mass()[a] / l[a])
        .collect();
    let mut t = DMatrix::zeros(n, n);
    for a in 0..n {
        let next = if a + 1 < n { k[a + 1] } else { 0.0 };
        t[(a, a)] = (k[a] + next) / m[a];
        if a + 1 < n {
            let off = -k[a + 1] / (m[a] * m[a + 1]).sqrt();
            t[(a, a + 1)] = off;
            t[(a + 1, a)] = off;
        }
    }
    let eig = t.symmetric_eigen();
    let c_norm = (0..n)
        .map(|a| p.cart_coupling(a).powi(2))
        .sum::<f64>()
        .sqrt();
    let mut margin = f64::INFINITY;
    for j in 0..n {
        let mu = eig.eigenvalues[j];
        let y: Vec<f64> = (0..n)
            .map(|a| eig.eigenvectors[(a, j)] / m[a].sqrt())
            .collect();
        let theta_norm = (0..n)
            .map(|a| {
                let prev = if a == 0 { 0.0 } else { y[a - 1] };
                ((y[a] - prev) / l[a]).powi(2)
            })
            .sum::<f64>()
            .sqrt();
        margin = margin.min((k[0] * y[0] / mu).abs() / (theta_norm * c_norm));
    }
    margin
}

#[test]
fn no_chain_equilibrium_is_uncontrollable_for_random_parameters() {
    // The module docs of `controllability` prove it (tridiagonal pencil in the mass
    // positions); this samples n = 1..6, every s, masses and lengths over a decade, and
    // checks the PBH margin against the independent tridiagonal oracle.
    let mut rng = StdRng::seed_from_u64(11);
    let (mut lo, mut worst) = (f64::INFINITY, 0.0f64);
    for n in 1..=6 {
        for _ in 0..8 {
            let params = random_params(&mut rng, n, 10.0);
            for s in all_signs(n).unwrap() {
                let c = controllability(&params, &s).unwrap();
                assert!(c.controllable, "n {n} s {s:?} {params:?}: {c:?}");
                let oracle = tridiagonal_margin(&params, &s);
                let rel = (c.margin - oracle).abs() / oracle;
                assert!(
                    rel < 1e-6,
                    "n {n} s {s:?}: PBH {} vs oracle {oracle}",
                    c.margin
                );
                lo = lo.min(c.margin);
                worst = worst.max(rel);
            }
        }
    }
    println!(
        "random chains (n <= 6, every s, ratios 10): smallest PBH margin {lo:.3e}, \
         largest relative difference to the tridiagonal oracle {worst:.1e}"
    );
}

#[test]
fn tiny_margins_are_real_and_reported_as_numerically_uncontrollable() {
    // Found by a random search over two decades of masses and lengths: a fast mode of
    // the hanging 6-link chain (lambda^2 = -2239) is localised on the short link 5 and
    // moves the cart only 7.7e-11 of the strongest coupling. Exactly controllable (the
    // oracle agrees with PBH), but far below the threshold: any stabilising gain would
    // be astronomically large, so the verdict is "uncontrollable" in double precision.
    let params = ChainParams::new(
        0.15,
        &[0.3378, 0.10735, 1.8319, 0.080919, 0.061094, 0.80697],
        &[3.2950, 0.12898, 9.2812, 3.5684, 0.11526, 0.74034],
        9.81,
    )
    .unwrap();
    let s = [1.0; 6];
    let c = controllability(&params, &s).unwrap();
    let oracle = tridiagonal_margin(&params, &s);
    println!(
        "localised mode: PBH margin {:.4e}, oracle {oracle:.4e}",
        c.margin
    );
    assert!(
        c.margin > 0.0 && c.margin < 1e-9 && !c.controllable,
        "{c:?}"
    );
    assert!((c.margin - oracle).abs() < 1e-3 * oracle);
}

#[test]
fn two_links_have_no_uncontrollable_mass_or_length_ratio() {
    // For n = 2 the only way to lose controllability is a mode v orthogonal to
    // c = (s_1 M_01, s_2 M_02), i.e. v ~ (c_2, -c_1), which is a mode iff G v and M v are
    // parallel. By hand: M v = (0, -s_1 m_1 m_2 l_1 l_2^2) and
    // G v = s_1 s_2 (m_1 + m_2) m_2 g l_1 l_2 (1, -1), so
    // det[G v, M v] = -s_2 (m_1 + m_2) m_1 m_2^2 g l_1^2 l_2^3 != 0 for every s and every
    // positive parameter. The scan confirms it over four decades of both ratios.
    let mut lo = (f64::INFINITY, 0.0, 0.0);
    for s in all_signs(2).unwrap() {
        for a in 0..=40 {
            for b in 0..=40 {
                let mass_ratio = 10f64.powf(-2.0 + 0.1 * a as f64);
                let length_ratio = 10f64.powf(-2.0 + 0.1 * b as f64);
                let params = ChainParams::new(
                    0.5,
                    &[0.1, 0.1 * mass_ratio],
                    &[0.1, 0.1 * length_ratio],
                    9.81,
                )
                .unwrap();
                let c = controllability(&params, &s).unwrap();
                assert!(
                    c.controllable,
                    "s {s:?}, m2/m1 {mass_ratio}, l2/l1 {length_ratio}"
                );
                if c.margin < lo.0 {
                    lo = (c.margin, mass_ratio, length_ratio);
                }
            }
        }
    }
    println!(
        "n = 2, ratios in [1e-2, 1e2]: smallest margin {:.2e} at m2/m1 = {:.2e}, l2/l1 = {:.2e}",
        lo.0, lo.1, lo.2
    );
}

#[test]
fn margin_vanishes_only_in_the_degenerate_limit_of_a_massless_tip() {
    // As m_n -> 0 the tip mode decouples from the cart: the margin goes to 0 but the
    // verdict stays "controllable" for every positive mass.
    let mut previous = f64::INFINITY;
    for tip in [1e-1, 1e-2, 1e-3, 1e-4, 1e-5] {
        let params = ChainParams::new(0.5, &[0.1, 0.1, tip], &[0.1, 0.1, 0.1], 9.81).unwrap();
        let c = controllability(&params, &[-1.0, 1.0, -1.0]).unwrap();
        println!("m_3 = {tip:e}: margin {:.3e}", c.margin);
        assert!(c.controllable && c.margin < previous);
        previous = c.margin;
    }
    assert!(previous < 1e-4);
}

/// Two pendulums side by side on the cart (not a chain): `M_qq = diag(m_a l_a^2, m_b l_b^2)`,
/// `G_qq = diag(m_a g l_a, m_b g l_b)`, `M_qx = (m_a l_a, m_b l_b)`, each times I2 / E.
fn parallel_pendulums(la: f64, lb: f64) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    let (ma, mb, g) = (0.2, 0.3, 9.81);
    let e = DMatrix::from_row_slice(2, 2, &[0.0, -1.0, 1.0, 0.0]);
    let eye = DMatrix::<f64>::identity(2, 2);
    let mut m = DMatrix::zeros(4, 4);
    let mut k = DMatrix::zeros(4, 4);
    let mut b = DMatrix::zeros(4, 2);
    for (i, (mass, len)) in [(ma, la), (mb, lb)].into_iter().enumerate() {
        m.view_mut((2 * i, 2 * i), (2, 2))
            .copy_from(&(&eye * (mass * len * len)));
        k.view_mut((2 * i, 2 * i), (2, 2))
            .copy_from(&(&eye * (mass * g * len)));
        b.view_mut((2 * i, 0), (2, 2))
            .copy_from(&(&e * (mass * len)));
    }
    (m, k, b)
}

#[test]
fn pbh_detects_equal_parallel_pendulums_and_only_them() {
    // Equal lengths: one frequency of multiplicity 4 with 2 inputs, uncontrollable.
    let (m, k, b) = parallel_pendulums(0.4, 0.4);
    let c = pbh_margin(&m, &k, &b).unwrap();
    assert!(
        !c.controllable && c.margin == 0.0 && c.weakest_multiplicity == 4,
        "{c:?}"
    );
    // Nearby lengths: distinct frequencies, each moving the cart: controllable.
    for lb in [0.4 * (1.0 + 1e-6), 0.4 * (1.0 - 1e-6), 0.5, 0.2] {
        let (m, k, b) = parallel_pendulums(0.4, lb);
        let c = pbh_margin(&m, &k, &b).unwrap();
        assert!(c.controllable && c.margin > 0.1, "l_b = {lb}: {c:?}");
    }
    // The verdict flips exactly where the frequencies coincide: bisection on it finds
    // l_b = l_a from a bracket that straddles it.
    let flips = |lb: f64| {
        let (m, k, b) = parallel_pendulums(0.4, lb);
        pbh_margin(&m, &k, &b).unwrap().controllable
    };
    // The detector also reports a mode orthogonal to the input with margin ~ 0.
    let (m, k, mut b) = parallel_pendulums(0.4, 0.5);
    b.view_mut((2, 0), (2, 2)).fill(0.0);
    let c = pbh_margin(&m, &k, &b).unwrap();
    assert!(!c.controllable && c.margin < CONTROLLABILITY_THRESHOLD);
    assert!(flips(0.3) && flips(0.5) && !flips(0.4));
}

fn care_residual(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
    x: &DMatrix<f64>,
) -> f64 {
    let s = b * r.clone().try_inverse().unwrap() * b.transpose();
    (a.transpose() * x + x * a - x * s * x + q).norm()
}

#[test]
fn riccati_double_integrator_closed_form() {
    // A = [[0,1],[0,0]], B = [0;1], Q = diag(q1, q2), R = r:
    // x12 = sqrt(q1 r), x22 = sqrt(r (q2 + 2 x12)), x11 = x12 x22 / r.
    for (q1, q2, r) in [(1.0, 1.0, 1.0), (8.0, 0.5, 0.2), (0.01, 3.0, 7.0)] {
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]);
        let b = DMatrix::from_column_slice(2, 1, &[0.0, 1.0]);
        let q = DMatrix::from_diagonal(&DVector::from_vec(vec![q1, q2]));
        let rm = DMatrix::from_element(1, 1, r);
        let sol = solve_care(&a, &b, &q, &rm).unwrap();
        let x12 = (q1 * r).sqrt();
        let x22 = (r * (q2 + 2.0 * x12)).sqrt();
        let exact = DMatrix::from_row_slice(2, 2, &[x12 * x22 / r, x12, x12, x22]);
        assert!(
            (&sol.x - &exact).amax() < 1e-12 * exact.amax(),
            "{} vs {exact}",
            sol.x
        );
    }
}

#[test]
fn riccati_on_the_paper_system_at_every_equilibrium() {
    // ||res|| / ||Q|| cannot go below ~eps ||X S X|| / ||Q||, and X reaches 4.5e7 at the
    // inverted equilibrium; the normalised residual (relative to the cancelling terms)
    // is the accuracy measure; ||res|| / ||Q|| is reported.
    let params = ChainParams::paper();
    let (mut worst_q, mut worst, mut iters, mut newton) = (0.0f64, 0.0f64, 0, 0);
    let mut max_x = 0.0f64;
    for s in all_signs(5).unwrap() {
        let ss = Linearization::new(&params, &s)
            .unwrap()
            .state_space()
            .unwrap();
        let w = LqrWeights::paper_default(&s);
        let sol = solve_care(&ss.a, &ss.b, &w.q, &w.r).unwrap();
        let res = care_residual(&ss.a, &ss.b, &w.q, &w.r, &sol.x);
        let s_mat = &ss.b * w.r.clone().try_inverse().unwrap() * ss.b.transpose();
        let cancelling = (&sol.x * s_mat * &sol.x).norm();
        let rel_q = res / w.q.norm();
        assert!(
            sol.residual < 1e-11,
            "{s:?}: normalised residual {:e}",
            sol.residual
        );
        // Round-off bound: the residual is a difference of terms of size ||X S X||.
        assert!(
            res < 1e-11 * (w.q.norm() + cancelling),
            "{s:?}: ||res|| {res:e}"
        );
        max_x = max_x.max(sol.x.norm());
        worst_q = worst_q.max(rel_q);
        worst = worst.max(sol.residual);
        iters = iters.max(sol.sign_iterations);
        newton = newton.max(sol.newton_steps);
        assert_eq!(sol.x, sol.x.transpose());
        let low = sol.x.clone().symmetric_eigen().eigenvalues.min();
        assert!(low > 0.0, "X must be positive definite for Q > 0: {low:e}");
        let closed = &ss.a - &ss.b * &sol.gain;
        assert!(spectral_abscissa(&closed) < 0.0);
        assert!((sol.closed_loop_abscissa - spectral_abscissa(&closed)).abs() < 1e-12);
    }
    println!(
        "paper system, 32 equilibria: normalised residual <= {worst:.2e}, ||res||/||Q|| <= \
         {worst_q:.2e} (||X|| up to {max_x:.1e}), sign iterations <= {iters}, Newton steps <= {newton}"
    );
}

#[test]
fn riccati_on_larger_systems_up_to_100_states() {
    // Uniform chains like the paper's, random well-spread ones, up to n = 24 (dim 100).
    // Upright long chains are left out on purpose: ||X|| grows ~100x per upright link
    // (4.5e7 inverted at n = 5, 1e12 at n = 8) and leaves double precision near n = 10;
    // the solver then errs (see `riccati_refuses_what_double_precision_cannot_hold`).
    let mut rng = StdRng::seed_from_u64(3);
    let uniform = |n| ChainParams::uniform(n, 0.5, 0.1, 0.1, 9.81).unwrap();
    let cases: Vec<(ChainParams, Vec<f64>)> = vec![
        (random_params(&mut rng, 1, 10.0), vec![-1.0]),
        (random_params(&mut rng, 3, 3.0), vec![-1.0, 1.0, -1.0]),
        (uniform(8), named_signs("folded", 8).unwrap()),
        (uniform(8), named_signs("inverted", 8).unwrap()),
        (random_params(&mut rng, 12, 2.0), vec![1.0; 12]),
        (uniform(24), vec![1.0; 24]),
    ];
    for (params, s) in cases {
        let n = s.len();
        let ss = Linearization::new(&params, &s)
            .unwrap()
            .state_space()
            .unwrap();
        let w = LqrWeights::paper_default(&s);
        let sol = solve_care(&ss.a, &ss.b, &w.q, &w.r).unwrap();
        println!(
            "n = {n} (dim {}) s {:?}..: normalised residual {:.2e}, ||X|| {:.1e}, sign \
             iterations {}, Newton {}",
            ss.a.nrows(),
            &s[..s.len().min(3)],
            sol.residual,
            sol.x.norm(),
            sol.sign_iterations,
            sol.newton_steps
        );
        assert!(sol.residual < 1e-6 && sol.closed_loop_abscissa < 0.0);
        assert!(spectral_abscissa(&(&ss.a - &ss.b * &sol.gain)) < 0.0);
    }
}

#[test]
fn riccati_refuses_what_double_precision_cannot_hold() {
    let params = ChainParams::uniform(12, 0.5, 0.1, 0.1, 9.81).unwrap();
    let s = vec![-1.0; 12];
    assert!(controllability(&params, &s).unwrap().controllable);
    let ss = Linearization::new(&params, &s)
        .unwrap()
        .state_space()
        .unwrap();
    let w = LqrWeights::paper_default(&s);
    let e = solve_care(&ss.a, &ss.b, &w.q, &w.r)
        .unwrap_err()
        .to_string();
    println!("inverted 12-link chain: {e}");
    assert!(e.contains("double precision"), "{e}");
}

#[test]
fn riccati_errors_are_clear() {
    let eye = |n| DMatrix::<f64>::identity(n, n);
    // An unstable mode the input cannot reach.
    let a = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, -1.0]);
    let b = DMatrix::from_column_slice(2, 1, &[0.0, 1.0]);
    let e = solve_care(&a, &b, &eye(2), &eye(1))
        .unwrap_err()
        .to_string();
    assert!(e.contains("no stabilising Riccati solution"), "{e}");
    // Undamped oscillation invisible to both B and Q: Hamiltonian eigenvalues on the axis.
    let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -1.0, 0.0]);
    let e = solve_care(&a, &DMatrix::zeros(2, 1), &DMatrix::zeros(2, 2), &eye(1))
        .unwrap_err()
        .to_string();
    assert!(e.contains("no stabilising Riccati solution"), "{e}");
    // Bad inputs, named.
    let a = eye(2);
    let b = DMatrix::from_column_slice(2, 1, &[0.0, 1.0]);
    let e = solve_care(&a, &b, &eye(3), &eye(1))
        .unwrap_err()
        .to_string();
    assert_eq!(e, "Q is 3x3, expected 2x2");
    let q = DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.0, 1.0]);
    let e = solve_care(&a, &b, &q, &eye(1)).unwrap_err().to_string();
    assert!(e.contains("Q is not symmetric"), "{e}");
    let q = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, -2.0]);
    let e = solve_care(&a, &b, &q, &eye(1)).unwrap_err().to_string();
    assert!(
        e.contains("Q has eigenvalue -2") && e.contains("semi-definite"),
        "{e}"
    );
    let e = solve_care(&a, &b, &eye(2), &DMatrix::zeros(1, 1))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("R has eigenvalue 0") && e.contains("positive definite"),
        "{e}"
    );
    let mut bad = eye(2);
    bad[(0, 1)] = f64::INFINITY;
    let e = solve_care(&bad, &b, &eye(2), &eye(1))
        .unwrap_err()
        .to_string();
    assert!(e.contains("A[0, 1] = inf"), "{e}");
}

#[test]
fn lqr_gains_stabilise_every_paper_equilibrium_and_match_eq_u() {
    let params = ChainParams::paper();
    let chain = SpatialChain::new(params.clone());
    let mut rng = StdRng::seed_from_u64(5);
    for s in all_signs(5).unwrap() {
        let c = LqrController::paper(&params, &s).unwrap();
        assert_eq!(c.gain().shape(), (2, 24));
        let ss = Linearization::new(&params, &s)
            .unwrap()
            .state_space()
            .unwrap();
        assert!(spectral_abscissa(&(&ss.a - &ss.b * c.gain())) < 0.0);
        // force(state) = -K z(state) with the controller's coordinates.
        let dz: Vec<f64> = (0..24).map(|_| rng.random_range(-0.05..0.05)).collect();
        let mut y = vec![0.0; chain.state_dim()];
        state_from_local(&s, &dz, &mut y).unwrap();
        let mut z = vec![0.0; 24];
        local_coordinates(&s, &y, &mut z).unwrap();
        let expected = -(c.gain() * DVector::from_vec(z));
        let u = c.force(&y);
        assert!((u - Vector2::new(expected[0], expected[1])).norm() < 1e-12 * expected.norm());
    }
}
