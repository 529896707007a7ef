//! Writes one raw RGB frame of the paper's Fig. 3 start (for eyeballing the renderer):
//! `cargo run --example render_frame -- OUT.rgb [WIDTH HEIGHT]`.

use chaincart::render::{render, FrameSpec};
use chaincart::{ChainParams, SpatialChain};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let out = args.get(1).cloned().unwrap_or_else(|| "frame.rgb".into());
    let width = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(640);
    let height = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(320);
    let chain = SpatialChain::new(ChainParams::paper());
    let mut y = chain.equilibrium(&[-1.0, -1.0, -1.0, 1.0, 1.0]).unwrap();
    let (a, b) = (6f64.to_radians(), 35f64.to_radians());
    y[4..7].copy_from_slice(&[-a.sin(), 0.0, -a.cos()]);
    y[16..19].copy_from_slice(&[-b.sin(), 0.3, b.cos()]);
    y[0] = 0.2;
    y[1] = 0.1;
    chain.project(&mut y);
    let mut pixels = vec![0u8; width * height * 3];
    let spec = FrameSpec {
        lengths: chain.params().lengths(),
        state: &y,
        target: Some(&[-1.0, -1.0, -1.0, 1.0, 1.0]),
        force: [12.0, -5.0],
        max_force: 20.0,
        track_limit: 0.5,
        top_view: true,
    };
    render(width, height, &spec, &mut pixels).expect("render");
    std::fs::write(&out, &pixels).expect("write frame");
}
