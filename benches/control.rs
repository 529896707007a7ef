//! Criterion benchmarks of the large-motion controllers (numbers in docs/performance.md).
//!
//! * `control_derivative/{model,generic}/<scene>`: one acceleration evaluation by the
//!   model's `Chain::derivative` and by the planner's scalar-generic copy at `f64`, side
//!   by side (the generic code could replace the model's if it is no slower).
//! * `control_jacobians/<scene>`: the exact Jacobians `A, B` of one control step (20 ms,
//!   2 RK4 substeps) by forward-mode dual numbers.
//! * `control_plan/<scene>`: planning the swing-up from hanging (default scene physics:
//!   1 kg cart, 0.1 kg at the end of each 0.5 m link, 20 N, 2.4 m track).
//! * `control_mpc/<scene>`: one receding-horizon control step (40 steps ahead, 2 iLQR
//!   iterations at most) along the swing-up, with the model stepping in between; the
//!   scene's control period is 20 ms, so the real-time factor is 20 ms / this time.

use chaincart::control::ChartPoint;
use chaincart::control::StepModel;
use chaincart::control::Vect;
use chaincart::control::{MpcOptions, PlanOptions, Planner, ScalarGeometry};
use chaincart::control::{ScalarChain, ScalarWorkspace};
use chaincart::geometry::Vector;
use chaincart::integrate::{Method, StepOptions, Stepper};
use chaincart::{Chain, ChainParams, Planar, Spatial};
use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::DMatrix;
use std::hint::black_box;

fn chain<G: ScalarGeometry>(n: usize) -> Chain<G> {
    Chain::new(ChainParams::uniform(n, 1.0, 0.1, 0.5, 9.81).unwrap())
}

/// A moving state: links tilted by growing angles from hanging, spinning.
fn moving<G: ScalarGeometry>(c: &Chain<G>) -> Vec<f64> {
    let mut y: Vec<f64> = (0..c.state_dim())
        .map(|k| 0.3 + 0.1 * (k as f64).sin())
        .collect();
    c.project(&mut y);
    y
}

fn derivative<G: ScalarGeometry>(crit: &mut Criterion, name: &str, n: usize) {
    let c = chain::<G>(n);
    let generic = ScalarChain::new(&c);
    let y = moving(&c);
    let u = vec![1.5; G::CART];
    let mut dy = vec![0.0; y.len()];
    let mut ws = c.workspace();
    let mut sws = ScalarWorkspace::<G, f64>::new(n);
    let mut group = crit.benchmark_group("control_derivative");
    group.bench_function(format!("model/{name}"), |b| {
        b.iter(|| c.derivative(black_box(&y), G::Cart::load(&u), &mut ws, &mut dy))
    });
    group.bench_function(format!("generic/{name}"), |b| {
        b.iter(|| generic.derivative(black_box(&y), G::CartS::<f64>::load(&u), &mut sws, &mut dy))
    });
    group.finish();
}

fn jacobians<G: ScalarGeometry>(crit: &mut Criterion, name: &str, n: usize) {
    let c = chain::<G>(n);
    let model = StepModel::new(&c, 0.02, 2);
    let mut ws = model.workspace();
    let mut y = moving(&c);
    let u = vec![1.5; G::CART];
    let base = ChartPoint::new::<G>(n, &y);
    model.step(&mut y, &u, &mut ws);
    let next = ChartPoint::new::<G>(n, &y);
    let nz = model.chart().dim();
    let (mut a, mut bm) = (DMatrix::zeros(nz, nz), DMatrix::zeros(nz, G::CART));
    crit.bench_function(&format!("control_jacobians/{name}"), |b| {
        b.iter(|| model.jacobians(black_box(&base), &u, &next, &mut a, &mut bm, &mut ws))
    });
}

fn options(n: usize) -> PlanOptions {
    PlanOptions {
        duration: 1.0 + n as f64,
        ..PlanOptions::default()
    }
}

fn plan<G: ScalarGeometry>(crit: &mut Criterion, name: &str, n: usize) {
    let c = chain::<G>(n);
    let start = c.equilibrium(&vec![1.0; n]).unwrap();
    let target = vec![-1.0; n];
    let mut group = crit.benchmark_group("control_plan");
    group.sample_size(10);
    group.bench_function(name, |b| {
        b.iter(|| {
            let mut planner = Planner::new(&c, &target, &options(n)).unwrap();
            black_box(planner.plan(&start).unwrap())
        })
    });
    group.finish();
}

fn mpc<G: ScalarGeometry>(crit: &mut Criterion, name: &str, n: usize) {
    let c = chain::<G>(n);
    let start = c.equilibrium(&vec![1.0; n]).unwrap();
    let mut planner = Planner::new(&c, &vec![-1.0; n], &options(n)).unwrap();
    let plan = planner.plan(&start).unwrap();
    let mut mpc = planner.mpc(MpcOptions::default()).unwrap();
    let steps = plan.forces.len() / G::CART + 50;
    let opts = StepOptions::new(Method::Rk4, 2).unwrap();
    let mut stepper = Stepper::new(&c);
    let mut y = start.clone();
    y[0] += 0.01;
    let mut k = 0;
    let mut u = vec![0.0; G::CART];
    let mut group = crit.benchmark_group("control_mpc");
    group.sample_size(20);
    group.bench_function(name, |b| {
        b.iter(|| {
            if k == steps {
                (k, y) = (0, start.clone());
                y[0] += 0.01;
                mpc.reset();
            }
            mpc.force(k, &y, &mut u);
            stepper
                .step(&c, &mut y, G::Cart::load(&u), 0.02, &opts)
                .unwrap();
            k += 1;
        })
    });
    group.finish();
}

fn benches(c: &mut Criterion) {
    derivative::<Planar>(c, "planar2", 2);
    derivative::<Planar>(c, "planar3", 3);
    derivative::<Spatial>(c, "spatial2", 2);
    derivative::<Spatial>(c, "spatial5", 5);
    jacobians::<Planar>(c, "planar2", 2);
    jacobians::<Planar>(c, "planar3", 3);
    jacobians::<Spatial>(c, "spatial2", 2);
    plan::<Planar>(c, "swingup-2", 2);
    plan::<Planar>(c, "swingup-3", 3);
    plan::<Spatial>(c, "spatial-swingup-2", 2);
    mpc::<Planar>(c, "swingup-2", 2);
    mpc::<Planar>(c, "swingup-3", 3);
    mpc::<Spatial>(c, "spatial-swingup-2", 2);
}

criterion_group!(control, benches);
criterion_main!(control);
