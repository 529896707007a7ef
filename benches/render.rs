//! Criterion benchmarks of the software renderer (the speed goal of the 3-D view:
//! at least 2,000 frames/s at 480x480 on one core for the paper's 5-link chain).
//!
//! * `render/<view>/<w>x<h>`: one frame of the paper's Fig. 3 start with the target
//!   ghost and a force arrow (and, in the 3-D view, a 50-point tip trail), into a
//!   reused buffer, on one thread. Throughput in frames.

use chaincart::render::{render, Camera, FrameSpec, ViewKind};
use chaincart::{ChainParams, SpatialChain};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;

fn frames(c: &mut Criterion) {
    let chain = SpatialChain::new(ChainParams::paper());
    let mut y = chain.equilibrium(&[-1.0, -1.0, -1.0, 1.0, 1.0]).unwrap();
    let (a, b) = (6f64.to_radians(), 35f64.to_radians());
    y[4..7].copy_from_slice(&[-a.sin(), 0.0, -a.cos()]);
    y[16..19].copy_from_slice(&[-b.sin(), 0.3, b.cos()]);
    chain.project(&mut y);
    let trail: Vec<[f64; 3]> = (0..50)
        .map(|k| {
            let t = 0.06 * k as f64;
            [0.2 * t.cos(), 0.2 * t.sin(), -0.3]
        })
        .collect();
    let mut group = c.benchmark_group("render");
    group.throughput(Throughput::Elements(1));
    for (view, width, height) in [
        (ViewKind::ThreeD, 480, 480),
        (ViewKind::ThreeD, 960, 720),
        (ViewKind::Side, 480, 240),
        (ViewKind::SideTop, 480, 240),
    ] {
        let spec = FrameSpec {
            lengths: chain.params().lengths(),
            state: &y,
            target: Some(&[-1.0, -1.0, -1.0, 1.0, 1.0]),
            force: [3.0, -1.0],
            max_force: 10.0,
            track_limit: 10.0,
            planar: false,
            view,
            camera: Camera::default(),
            trail: &trail,
        };
        let mut pixels = vec![0u8; width * height * 3];
        group.bench_function(format!("{}/{width}x{height}", view.name()), |bench| {
            bench.iter(|| render(width, height, black_box(&spec), &mut pixels).unwrap())
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).warm_up_time(std::time::Duration::from_millis(300)).measurement_time(std::time::Duration::from_millis(1000));
    targets = frames
}
criterion_main!(benches);
