//! Writes one frame of the paper's Fig. 3 start as a binary PPM image (for eyeballing
//! the renderer): `cargo run --example render_frame -- OUT.ppm [WIDTH HEIGHT [VIEW]]`,
//! VIEW one of `3d` (default), `side`, `top`, `side+top`.

use chaincart::render::{render, Camera, FrameSpec, ViewKind};
use chaincart::{ChainParams, SpatialChain};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let out = args.get(1).cloned().unwrap_or_else(|| "frame.ppm".into());
    let width = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(640);
    let height = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(480);
    let view = ViewKind::from_name(args.get(4).map_or("3d", |s| s.as_str())).expect("view");
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
        planar: false,
        view,
        camera: Camera::default(),
        trail: &[],
    };
    render(width, height, &spec, &mut pixels).expect("render");
    let mut image = format!("P6\n{width} {height}\n255\n").into_bytes();
    image.extend_from_slice(&pixels);
    std::fs::write(&out, image).expect("write frame");
}
