//! The 3-D view: a perspective picture of the chain on its cart, lit, over a floor
//! with a grid, with each body's shadow on the floor (so height reads at a glance),
//! the track and its limits, the target configuration as a faint ghost, the tip's
//! trail and the applied force as an arrow.
//!
//! Sizes are proportions of the chain's length `L`, so every scene draws alike: the
//! cart rides at height 0 on its track; the floor lies `1.08 L` below it, under the
//! reach of the hanging chain.

use super::camera::{add_scaled, dot, framing_distance, sub, Camera, Projection};
use super::raster::{faces_camera, screen_box, Color, Floor, Paint, Raster, Scratch};
use super::scene::{finite_or, nice_step, FrameSpec};
use std::cell::RefCell;

const CART: Color = [52.0, 92.0, 196.0];
const LINK: Color = [58.0, 58.0, 64.0];
const MASS: Color = [236.0, 128.0, 36.0];
const GHOST: Color = [120.0, 124.0, 138.0];
const TRACK: Color = [150.0, 152.0, 158.0];
const STOP: Color = [110.0, 112.0, 120.0];
const FORCE: Color = [214.0, 38.0, 38.0];
const TRAIL: Color = [150.0, 60.0, 190.0];

/// Depth of the floor below the cart, in chain lengths.
const FLOOR_DEPTH: f64 = 1.08;
/// Opacity of the target's ghost.
const GHOST_ALPHA: f32 = 0.3;
/// The ghost's rods and masses, as a fraction of the chain's.
const GHOST_SCALE: f64 = 0.7;

/// Proportions of the bodies, from the chain's length and its shortest link.
#[derive(Debug, Clone, Copy)]
struct Sizes {
    chain: f64,
    link_radius: f64,
    mass_radius: f64,
    cart_half: [f64; 3],
    rail_radius: f64,
    floor: f64,
}

impl Sizes {
    fn new(lengths: &[f64]) -> Self {
        let chain = lengths.iter().map(|l| l.abs()).sum::<f64>().max(1e-9);
        let shortest = lengths
            .iter()
            .map(|l| l.abs())
            .fold(f64::INFINITY, f64::min);
        Self {
            chain,
            link_radius: 0.02 * chain,
            mass_radius: (0.2 * shortest).clamp(0.025 * chain, 0.05 * chain),
            cart_half: [0.12 * chain, 0.08 * chain, 0.05 * chain],
            rail_radius: 0.011 * chain,
            floor: -FLOOR_DEPTH * chain,
        }
    }
}

/// A shape of the scene in the z-up frame relative to the anchor.
#[derive(Debug, Clone, Copy)]
enum Shape {
    Sphere {
        center: [f64; 3],
        radius: f64,
    },
    Rod {
        a: [f64; 3],
        b: [f64; 3],
        radius: f64,
    },
    /// A box face: corners in order, which edges it shares with another visible
    /// face, and its outward normal.
    Face {
        corners: [[f64; 3]; 4],
        inner: [bool; 4],
        normal: [f64; 3],
    },
    /// A flat arrowhead facing the camera, from `base` to `tip`.
    Arrowhead {
        base: [f64; 3],
        tip: [f64; 3],
        half_width: f64,
    },
}

#[derive(Debug, Clone, Copy)]
struct Item {
    shape: Shape,
    paint: Paint,
    /// Depth used to draw far to near.
    depth: f64,
}

fn solid(color: Color) -> Paint {
    Paint {
        color,
        alpha: 1.0,
        solid: true,
    }
}

fn ghost() -> Paint {
    Paint {
        color: GHOST,
        alpha: GHOST_ALPHA,
        solid: false,
    }
}

/// Model coordinates (e3 along gravity) to the z-up frame relative to `anchor`.
fn lift(p: [f64; 3], anchor: [f64; 2]) -> [f64; 3] {
    [p[0] - anchor[0], p[1] - anchor[1], -p[2]]
}

/// Points of the chain (z-up, relative to the cart): the pivot, then each mass.
fn chain_points(lengths: &[f64], direction: impl Fn(usize) -> [f64; 3]) -> Vec<[f64; 3]> {
    let mut p = [0.0; 3];
    let mut out = Vec::with_capacity(lengths.len() + 1);
    out.push(p);
    for (i, &l) in lengths.iter().enumerate() {
        let q = direction(i);
        p = [p[0] + l * q[0], p[1] + l * q[1], p[2] - l * q[2]];
        out.push(p);
    }
    out
}

/// The camera of one frame: whether it follows the cart, the anchor (the cart or the
/// track's centre), and the projection.
struct Framing {
    anchor: [f64; 2],
    projection: Projection,
    /// Half-extent along e1 (and e2) beyond which the track is not drawn, m.
    reach: f64,
}

/// Points the automatic framing keeps in view, relative to the anchor: the chain's
/// reach about the cart (a sphere of radius `L`, a disc in the e1-e3 plane for planar
/// chains) at each place the cart can be seen at, and the floor beneath it where
/// the shadows fall.
fn framed_points(cart_places: &[[f64; 2]], sizes: &Sizes, planar: bool) -> Vec<[f64; 3]> {
    let reach = sizes.chain + sizes.mass_radius;
    let mut directions = Vec::with_capacity(26);
    for i in -1i32..=1 {
        for j in -1i32..=1 {
            for k in -1i32..=1 {
                if (i, j, k) != (0, 0, 0) && !(planar && j != 0) {
                    let n = ((i * i + j * j + k * k) as f64).sqrt();
                    directions.push([i as f64 / n, j as f64 / n, k as f64 / n]);
                }
            }
        }
    }
    let mut points = Vec::with_capacity(cart_places.len() * (directions.len() + 4));
    for c in cart_places {
        points.extend(
            directions
                .iter()
                .map(|d| [c[0] + reach * d[0], c[1] + reach * d[1], reach * d[2]]),
        );
        let side = if planar {
            sizes.cart_half[1]
        } else {
            0.4 * sizes.chain
        };
        for (dx, dy) in [(-0.4, -1.0), (0.4, -1.0), (-0.4, 1.0), (0.4, 1.0)] {
            points.push([c[0] + dx * sizes.chain, c[1] + dy * side, sizes.floor]);
        }
    }
    points
}

fn frame_camera(
    spec: &FrameSpec,
    camera: &Camera,
    sizes: &Sizes,
    cart: [f64; 2],
    w: usize,
    h: usize,
) -> Framing {
    let chain = sizes.chain;
    let track = if spec.track_limit.is_finite() {
        spec.track_limit.max(0.0)
    } else {
        f64::INFINITY
    };
    let follow = camera.follow.unwrap_or(track > 2.0 * chain);
    let anchor = if follow { cart } else { [0.0, 0.0] };
    let places: Vec<[f64; 2]> = if follow {
        vec![[0.0, 0.0]]
    } else if spec.planar {
        vec![[-track, 0.0], [track, 0.0]]
    } else {
        vec![
            [-track, -track],
            [track, -track],
            [-track, track],
            [track, track],
        ]
    };
    let points = framed_points(&places, sizes, spec.planar);
    let (lo, hi) = points.iter().fold(
        ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
        |(lo, hi), q| {
            (
                [lo[0].min(q[0]), lo[1].min(q[1]), lo[2].min(q[2])],
                [hi[0].max(q[0]), hi[1].max(q[1]), hi[2].max(q[2])],
            )
        },
    );
    let center = [
        0.5 * (lo[0] + hi[0]),
        0.5 * (lo[1] + hi[1]),
        0.5 * (lo[2] + hi[2]),
    ];
    let relative: Vec<[f64; 3]> = points.iter().map(|q| sub(*q, center)).collect();
    let focal = super::camera::focal_length(camera.fov, h);
    let distance = camera.distance.unwrap_or_else(|| {
        framing_distance(camera.basis(), &relative, focal, w, h).max(0.5 * chain)
    });
    let projection = Projection::new(camera, center, distance, w, h);
    Framing {
        anchor,
        projection,
        reach: 3.0 * distance + 2.0 * chain,
    }
}

/// Rods longer than their depth allows are cut into pieces, each drawn with the
/// radius of its own depth.
fn push_rod(
    items: &mut Vec<Item>,
    p: &Projection,
    a: [f64; 3],
    b: [f64; 3],
    radius: f64,
    paint: Paint,
) {
    let Some((a, b)) = p.clip_segment(a, b) else {
        return;
    };
    let (za, zb) = (p.to_camera(a)[2], p.to_camera(b)[2]);
    let ratio = za.max(zb) / za.min(zb).max(p.near);
    let pieces = if ratio.is_finite() {
        (ratio.ln() / 1.3f64.ln()).ceil().clamp(1.0, 32.0) as usize
    } else {
        1
    };
    for k in 0..pieces {
        let (s, t) = (k as f64 / pieces as f64, (k + 1) as f64 / pieces as f64);
        let (pa, pb) = (add_scaled(a, s, sub(b, a)), add_scaled(a, t, sub(b, a)));
        if off_screen(p, pa, pb, radius) {
            continue;
        }
        let depth = 0.5 * (p.to_camera(pa)[2] + p.to_camera(pb)[2]);
        items.push(Item {
            shape: Shape::Rod {
                a: pa,
                b: pb,
                radius,
            },
            paint,
            depth,
        });
    }
}

/// Whether a rod from `a` to `b` lies wholly to one side of the frame.
fn off_screen(p: &Projection, a: [f64; 3], b: [f64; 3], radius: f64) -> bool {
    let (Some(sa), Some(sb)) = (p.project(a), p.project(b)) else {
        return false;
    };
    let margin = 2.0 + radius * p.scale_at(sa.z.min(sb.z));
    let (w, h) = (2.0 * p.center[0], 2.0 * p.center[1]);
    sa.x.max(sb.x) < -margin
        || sa.x.min(sb.x) > w + margin
        || sa.y.max(sb.y) < -margin
        || sa.y.min(sb.y) > h + margin
}

fn push_sphere(items: &mut Vec<Item>, p: &Projection, center: [f64; 3], radius: f64, paint: Paint) {
    items.push(Item {
        shape: Shape::Sphere { center, radius },
        paint,
        depth: p.to_camera(center)[2],
    });
}

/// The visible faces of an axis-aligned box of half-extents `half` about `center`;
/// edges shared by two visible faces are marked inner (drawn without a seam).
fn push_box(items: &mut Vec<Item>, p: &Projection, center: [f64; 3], half: [f64; 3], color: Color) {
    let corner = |i: usize| {
        [
            center[0] + if i & 1 == 0 { -half[0] } else { half[0] },
            center[1] + if i & 2 == 0 { -half[1] } else { half[1] },
            center[2] + if i & 4 == 0 { -half[2] } else { half[2] },
        ]
    };
    // Faces as corner indices in order around them, with outward normals.
    const FACES: [([usize; 4], [f64; 3]); 6] = [
        ([0, 2, 6, 4], [-1.0, 0.0, 0.0]),
        ([1, 5, 7, 3], [1.0, 0.0, 0.0]),
        ([0, 4, 5, 1], [0.0, -1.0, 0.0]),
        ([2, 3, 7, 6], [0.0, 1.0, 0.0]),
        ([0, 1, 3, 2], [0.0, 0.0, -1.0]),
        ([4, 6, 7, 5], [0.0, 0.0, 1.0]),
    ];
    let visible: Vec<bool> = FACES
        .iter()
        .map(|(idx, n)| faces_camera(p, corner(idx[0]), *n))
        .collect();
    let shared = |a: usize, b: usize, own: usize| {
        FACES.iter().enumerate().any(|(f, (idx, _))| {
            f != own
                && visible[f]
                && (0..4).any(|k| {
                    (idx[k], idx[(k + 1) % 4]) == (b, a) || (idx[k], idx[(k + 1) % 4]) == (a, b)
                })
        })
    };
    for (f, (idx, normal)) in FACES.iter().enumerate() {
        if !visible[f] {
            continue;
        }
        let corners = idx.map(corner);
        let inner = [0, 1, 2, 3].map(|k| shared(idx[k], idx[(k + 1) % 4], f));
        let c = corners
            .iter()
            .fold([0.0; 3], |acc, q| add_scaled(acc, 0.25, *q));
        items.push(Item {
            shape: Shape::Face {
                corners,
                inner,
                normal: *normal,
            },
            paint: solid(color),
            depth: p.to_camera(c)[2],
        });
    }
}

/// The track: a rail along e1 (planar) or the square of the cart's limits
/// (spatial), with end stops and posts down to the floor at the limits. Only the
/// part within `reach` of the anchor is drawn.
fn push_track(items: &mut Vec<Item>, spec: &FrameSpec, sizes: &Sizes, framing: &Framing) {
    let p = &framing.projection;
    let track = if spec.track_limit.is_finite() {
        spec.track_limit.max(0.0)
    } else {
        f64::INFINITY
    };
    let a = framing.anchor;
    let (lo, hi) = ([-track - a[0], -track - a[1]], [track - a[0], track - a[1]]);
    let r = framing.reach;
    let clip = |v: f64| v.clamp(-r, r);
    let rail = solid(TRACK);
    let posts: Vec<[f64; 2]> = if spec.planar {
        push_rod(
            items,
            p,
            [clip(lo[0]), 0.0, 0.0],
            [clip(hi[0]), 0.0, 0.0],
            sizes.rail_radius,
            rail,
        );
        vec![[lo[0], 0.0], [hi[0], 0.0]]
    } else {
        if track.is_finite() {
            for y in [lo[1], hi[1]].into_iter().filter(|y| y.abs() <= r) {
                push_rod(
                    items,
                    p,
                    [clip(lo[0]), y, 0.0],
                    [clip(hi[0]), y, 0.0],
                    sizes.rail_radius,
                    rail,
                );
            }
            for x in [lo[0], hi[0]].into_iter().filter(|x| x.abs() <= r) {
                push_rod(
                    items,
                    p,
                    [x, clip(lo[1]), 0.0],
                    [x, clip(hi[1]), 0.0],
                    sizes.rail_radius,
                    rail,
                );
            }
        }
        vec![
            [lo[0], lo[1]],
            [hi[0], lo[1]],
            [lo[0], hi[1]],
            [hi[0], hi[1]],
        ]
    };
    if !track.is_finite() {
        return;
    }
    for [x, y] in posts {
        if x.abs() > r || y.abs() > r {
            continue;
        }
        let stop = [
            0.35 * sizes.cart_half[2],
            2.0 * sizes.rail_radius,
            1.6 * sizes.cart_half[2],
        ];
        push_box(items, p, [x, y, 0.0], stop, STOP);
        push_rod(
            items,
            p,
            [x, y, 0.0],
            [x, y, sizes.floor],
            0.8 * sizes.rail_radius,
            solid(STOP),
        );
    }
}

/// The force as an arrow from the cart's side, `max_force` drawn 60% of the chain
/// long; none for a zero force.
fn push_force(
    items: &mut Vec<Item>,
    spec: &FrameSpec,
    sizes: &Sizes,
    p: &Projection,
    cart: [f64; 3],
) {
    if spec.max_force.is_nan() || spec.max_force <= 0.0 {
        return;
    }
    let f = [spec.force[0], spec.force[1]];
    let magnitude = f[0].hypot(f[1]);
    if !(magnitude.is_finite() && magnitude > 0.0) {
        return;
    }
    let length = (0.6 * sizes.chain * magnitude / spec.max_force).min(2.0 * sizes.chain);
    if length < 0.02 * sizes.chain {
        return;
    }
    let u = [f[0] / magnitude, f[1] / magnitude, 0.0];
    let start = add_scaled(cart, sizes.cart_half[0], u);
    let tip = add_scaled(start, length, u);
    let head = (0.35 * length).min(0.12 * sizes.chain);
    let base = add_scaled(tip, -head, u);
    push_rod(
        items,
        p,
        start,
        base,
        0.6 * sizes.rail_radius + 0.004 * sizes.chain,
        solid(FORCE),
    );
    items.push(Item {
        shape: Shape::Arrowhead {
            base,
            tip,
            half_width: 0.45 * head,
        },
        paint: solid(FORCE),
        depth: p.to_camera(base)[2],
    });
}

/// The chain's shadows on the floor: links, masses and the cart, each blurred and
/// lightened with its height.
#[allow(clippy::too_many_arguments)]
fn draw_shadows(
    raster: &mut Raster,
    p: &Projection,
    floor: &Floor,
    sizes: &Sizes,
    cart: [f64; 3],
    points: &[[f64; 3]],
    w: usize,
    h: usize,
) {
    let ground = |q: [f64; 3]| [q[0] + floor.offset[0], q[1] + floor.offset[1]];
    let cast = |a: [f64; 3], b: [f64; 3], radius: f64, raster: &mut Raster| {
        let height = 0.5 * (a[2] + b[2]) - floor.height;
        if !(height.is_finite() && height >= 0.0) {
            return;
        }
        let blur = 0.01 * sizes.chain + 0.025 * height;
        let strength = (0.75 - 0.25 * height / sizes.chain).clamp(0.3, 0.75) as f32;
        let reach = radius + blur;
        let corners: Vec<[f64; 3]> = [a, b]
            .iter()
            .flat_map(|q| {
                [
                    [-reach, -reach],
                    [reach, -reach],
                    [-reach, reach],
                    [reach, reach],
                ]
                .map(|d| [q[0] + d[0], q[1] + d[1], floor.height])
            })
            .collect();
        let screen = screen_box(p, &corners, w, h);
        raster.shadow(ground(a), ground(b), radius, blur, strength, screen);
    };
    let c = sizes.cart_half;
    cast(
        add_scaled(cart, c[1] - c[0], [1.0, 0.0, 0.0]),
        add_scaled(cart, c[0] - c[1], [1.0, 0.0, 0.0]),
        c[1],
        raster,
    );
    for pair in points.windows(2) {
        cast(pair[0], pair[1], sizes.link_radius, raster);
    }
    for &q in &points[1..] {
        cast(q, q, sizes.mass_radius, raster);
    }
}

/// The tip's recent path as a line fading into the past.
fn draw_trail(
    raster: &mut Raster,
    p: &Projection,
    trail: &[[f64; 3]],
    anchor: [f64; 2],
    chain: f64,
) {
    let count = trail.len();
    for (k, pair) in trail.windows(2).enumerate() {
        let (a, b) = (lift(pair[0], anchor), lift(pair[1], anchor));
        let Some((a, b)) = p.clip_segment(a, b) else {
            continue;
        };
        let (Some(sa), Some(sb)) = (p.project(a), p.project(b)) else {
            continue;
        };
        let age = (k + 1) as f32 / count as f32;
        let width = (0.005 * chain * p.scale_at(0.5 * (sa.z + sb.z))).clamp(0.8, 3.0);
        raster.trail_stroke([sa.x, sa.y], [sb.x, sb.y], width, 0.15 + 0.7 * age);
    }
}

fn draw_item(raster: &mut Raster, p: &Projection, item: &Item) {
    match item.shape {
        Shape::Sphere { center, radius } => {
            if let Some(s) = p.project(center) {
                raster.sphere(s, radius * p.scale_at(s.z), radius, &item.paint);
            }
        }
        Shape::Rod { a, b, radius } => {
            if let (Some(sa), Some(sb)) = (p.project(a), p.project(b)) {
                let r_px = radius * p.scale_at(0.5 * (sa.z + sb.z));
                raster.rod(sa, sb, r_px, radius, &item.paint);
            }
        }
        Shape::Face {
            corners,
            inner,
            normal,
        } => {
            let projected: Option<Vec<_>> = corners.iter().map(|&c| p.project(c)).collect();
            if let Some(v) = projected {
                let n = [
                    dot(normal, p.right),
                    dot(normal, p.up),
                    dot(normal, p.forward),
                ];
                let color = raster.face_color(item.paint.color, n);
                raster.polygon(&v, &inner, color, &item.paint);
            }
        }
        Shape::Arrowhead {
            base,
            tip,
            half_width,
        } => {
            let (Some(b), Some(t)) = (p.project(base), p.project(tip)) else {
                return;
            };
            let (dx, dy) = (t.x - b.x, t.y - b.y);
            let len = dx.hypot(dy);
            if len < 0.5 {
                return;
            }
            let w = half_width * p.scale_at(b.z);
            let (nx, ny) = (-dy / len * w, dx / len * w);
            let left = super::camera::ScreenPoint {
                x: b.x + nx,
                y: b.y + ny,
                z: b.z,
            };
            let right = super::camera::ScreenPoint {
                x: b.x - nx,
                y: b.y - ny,
                z: b.z,
            };
            raster.polygon(
                &[left, t, right],
                &[false; 3],
                item.paint.color,
                &item.paint,
            );
        }
    }
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

/// Draws the 3-D view of `spec` seen by `camera` into `pixels` (`height x width x 3`).
pub fn draw_3d(width: usize, height: usize, spec: &FrameSpec, camera: &Camera, pixels: &mut [u8]) {
    SCRATCH.with(|scratch| {
        let mut scratch = scratch.borrow_mut();
        let mut raster = Raster::new(width, height, pixels, &mut scratch);
        compose(&mut raster, width, height, spec, camera);
    });
}

fn compose(raster: &mut Raster, w: usize, h: usize, spec: &FrameSpec, camera: &Camera) {
    let y = spec.state;
    let cart_world = [finite_or(y[0], 0.0), finite_or(y[1], 0.0)];
    let sizes = Sizes::new(spec.lengths);
    let framing = frame_camera(spec, camera, &sizes, cart_world, w, h);
    let p = framing.projection;
    let cart = [
        cart_world[0] - framing.anchor[0],
        cart_world[1] - framing.anchor[1],
        0.0,
    ];
    let q = |i: usize| [y[4 + 3 * i], y[5 + 3 * i], y[6 + 3 * i]];
    let points: Vec<[f64; 3]> = chain_points(spec.lengths, q)
        .into_iter()
        .map(|v| add_scaled(v, 1.0, cart))
        .collect();
    let spacing = nice_step(sizes.chain);
    let floor = Floor {
        height: sizes.floor,
        spacing,
        offset: [
            framing.anchor[0].rem_euclid(spacing),
            framing.anchor[1].rem_euclid(spacing),
        ],
        fog: 4.0 * (p.to_camera([0.0; 3])[2]).abs().max(sizes.chain),
    };
    raster.map_floor(&p, &floor);
    draw_shadows(raster, &p, &floor, &sizes, cart, &points, w, h);
    draw_trail(raster, &p, spec.trail, framing.anchor, sizes.chain);
    raster.background(&floor, TRAIL);

    let mut items = Vec::with_capacity(64);
    push_track(&mut items, spec, &sizes, &framing);
    push_box(&mut items, &p, cart, sizes.cart_half, CART);
    for pair in points.windows(2) {
        push_rod(
            &mut items,
            &p,
            pair[0],
            pair[1],
            sizes.link_radius,
            solid(LINK),
        );
    }
    for &m in &points[1..] {
        push_sphere(&mut items, &p, m, sizes.mass_radius, solid(MASS));
    }
    push_force(&mut items, spec, &sizes, &p, cart);
    let opaque = items.len();
    if let Some(signs) = spec.target {
        let ghost_points: Vec<[f64; 3]> = chain_points(spec.lengths, |i| [0.0, 0.0, signs[i]])
            .into_iter()
            .map(|v| add_scaled(v, 1.0, cart))
            .collect();
        // Slimmer than the chain, so that the chain reads in front of its target.
        for pair in ghost_points.windows(2) {
            push_rod(
                &mut items,
                &p,
                pair[0],
                pair[1],
                GHOST_SCALE * sizes.link_radius,
                ghost(),
            );
        }
        for &m in &ghost_points[1..] {
            push_sphere(&mut items, &p, m, GHOST_SCALE * sizes.mass_radius, ghost());
        }
    }
    // Far to near, solid bodies first, then the translucent ghost over them.
    items[..opaque].sort_by(|a, b| b.depth.total_cmp(&a.depth));
    items[opaque..].sort_by(|a, b| b.depth.total_cmp(&a.depth));
    for item in &items {
        draw_item(raster, &p, item);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::{render, ViewKind};
    use crate::{ChainParams, SpatialChain};

    const W: usize = 160;
    const H: usize = 120;

    fn spec<'a>(state: &'a [f64], lengths: &'a [f64]) -> FrameSpec<'a> {
        FrameSpec {
            lengths,
            state,
            target: None,
            force: [0.0; 2],
            max_force: 10.0,
            track_limit: 10.0,
            planar: false,
            view: ViewKind::ThreeD,
            camera: Camera::default(),
            trail: &[],
        }
    }

    fn draw(spec: &FrameSpec) -> Vec<u8> {
        let mut px = vec![0u8; W * H * 3];
        render(W, H, spec, &mut px).unwrap();
        px
    }

    fn pixel(px: &[u8], x: f64, y: f64) -> [u8; 3] {
        let i = 3 * (y as usize * W + x as usize);
        [px[i], px[i + 1], px[i + 2]]
    }

    fn luminance(c: [u8; 3]) -> f64 {
        c.iter().map(|&v| v as f64).sum::<f64>() / 3.0
    }

    fn paper(signs: &[f64]) -> Vec<f64> {
        SpatialChain::new(ChainParams::paper())
            .equilibrium(signs)
            .unwrap()
    }

    /// The projection the scene uses for `spec`, and the anchor.
    fn projection_of(spec: &FrameSpec) -> Framing {
        let sizes = Sizes::new(spec.lengths);
        frame_camera(
            spec,
            &spec.camera,
            &sizes,
            [spec.state[0], spec.state[1]],
            W,
            H,
        )
    }

    #[test]
    fn frames_are_deterministic_and_far_from_uniform() {
        let y = paper(&[-1.0, -1.0, -1.0, 1.0, 1.0]);
        let s = FrameSpec {
            target: Some(&[-1.0; 5]),
            force: [4.0, -2.0],
            ..spec(&y, &[0.1; 5])
        };
        let a = draw(&s);
        assert_eq!(a, draw(&s));
        let mean = a.iter().map(|&v| v as f64).sum::<f64>() / a.len() as f64;
        let spread =
            (a.iter().map(|&v| (v as f64 - mean).powi(2)).sum::<f64>() / a.len() as f64).sqrt();
        let mut colors: Vec<[u8; 3]> = a.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        colors.sort_unstable();
        colors.dedup();
        assert!(
            spread > 5.0 && colors.len() > 200,
            "{spread} {}",
            colors.len()
        );
    }

    #[test]
    fn the_cart_and_the_masses_land_where_the_camera_projects_them() {
        let y = paper(&[1.0; 5]);
        let lengths = [0.1; 5];
        let s = spec(&y, &lengths);
        let px = draw(&s);
        let f = projection_of(&s);
        // The cart's centre is blue; the tip mass (0.5 m below it) orange.
        let cart = f.projection.project([0.0, 0.0, 0.0]).unwrap();
        let c = pixel(&px, cart.x, cart.y);
        assert!(c[2] > c[0] + 40, "cart pixel {c:?}");
        let tip = f.projection.project([0.0, 0.0, -0.5]).unwrap();
        let m = pixel(&px, tip.x, tip.y);
        assert!(m[0] > m[2] + 60, "tip pixel {m:?}");
        // The hanging chain runs down the screen from the cart.
        assert!(tip.y > cart.y + 20.0);
    }

    #[test]
    fn a_near_mass_hides_the_cart_behind_it() {
        // A link pointing from the cart straight at the camera puts its mass between
        // the camera and the cart: at the cart's centre pixel the mass shows.
        let camera = Camera::default();
        let [_, _, forward] = camera.basis();
        let lengths = [0.05];
        let mut y = vec![0.0; 10];
        // q in model coordinates (e3 down): the z-up forward flipped in its third part.
        y[4..7].copy_from_slice(&[-forward[0], -forward[1], forward[2]]);
        let s = FrameSpec {
            track_limit: 10.0,
            ..spec(&y, &lengths)
        };
        let px = draw(&s);
        let f = projection_of(&s);
        let cart = f.projection.project([0.0; 3]).unwrap();
        let c = pixel(&px, cart.x, cart.y);
        assert!(c[0] > c[2] + 60, "the mass, not the cart: {c:?}");
        // Pointing away from the camera, the cart hides the mass.
        y[4..7].copy_from_slice(&[forward[0], forward[1], -forward[2]]);
        let px = draw(&FrameSpec {
            ..spec(&y, &lengths)
        });
        let c = pixel(&px, cart.x, cart.y);
        assert!(c[2] > c[0] + 40, "the cart, not the mass: {c:?}");
    }

    #[test]
    fn bodies_cast_shadows_straight_down() {
        let y = paper(&[1.0; 5]);
        let lengths = [0.1; 5];
        let s = spec(&y, &lengths);
        let f = projection_of(&s);
        let sizes = Sizes::new(&lengths);
        let under = f.projection.project([0.0, 0.0, sizes.floor]).unwrap();
        let aside = f.projection.project([0.3, -0.3, sizes.floor]).unwrap();
        let px = draw(&s);
        let dark = luminance(pixel(&px, under.x, under.y));
        let bright = luminance(pixel(&px, aside.x, aside.y));
        assert!(dark < bright - 20.0, "{dark} vs {bright}");
    }

    #[test]
    fn the_trail_the_ghost_and_the_force_each_show() {
        let y = paper(&[1.0; 5]);
        let lengths = [0.1; 5];
        let plain = draw(&spec(&y, &lengths));
        let trail: Vec<[f64; 3]> = (0..20).map(|k| [0.02 * k as f64, 0.0, 0.3]).collect();
        let cases = [
            FrameSpec {
                trail: &trail,
                ..spec(&y, &lengths)
            },
            FrameSpec {
                target: Some(&[-1.0; 5]),
                ..spec(&y, &lengths)
            },
            FrameSpec {
                force: [5.0, 5.0],
                ..spec(&y, &lengths)
            },
        ];
        for s in &cases {
            assert_ne!(draw(s), plain);
        }
    }

    #[test]
    fn a_fixed_camera_shows_the_cart_move() {
        let mut y = paper(&[1.0; 5]);
        let lengths = [0.1; 5];
        let fixed = Camera {
            follow: Some(false),
            ..Camera::default()
        };
        let s = FrameSpec {
            camera: fixed,
            track_limit: 0.5,
            planar: false,
            ..spec(&y, &lengths)
        };
        let before = projection_of(&s);
        y[0] = 0.4;
        let s = FrameSpec {
            camera: fixed,
            track_limit: 0.5,
            ..spec(&y, &lengths)
        };
        let after = projection_of(&s);
        assert_eq!(before.anchor, after.anchor);
        // Following, the anchor moves with the cart.
        let s = FrameSpec {
            camera: Camera {
                follow: Some(true),
                ..fixed
            },
            ..s
        };
        assert_eq!(projection_of(&s).anchor, [0.4, 0.0]);
    }

    #[test]
    fn wild_states_and_cameras_draw_without_panicking() {
        let lengths = [0.1; 5];
        let mut y = paper(&[1.0; 5]);
        y[0] = 1e300;
        y[5] = f64::NAN;
        y[9] = -1e300;
        let trail = [[f64::NAN, 0.0, 0.0], [1e300, 0.0, 0.0], [0.0, 0.0, 0.0]];
        for camera in [
            Camera::default(),
            Camera {
                elevation: 90.0,
                ..Camera::default()
            },
            Camera {
                elevation: -90.0,
                ..Camera::default()
            },
            Camera {
                distance: Some(1e-6),
                ..Camera::default()
            },
            Camera {
                distance: Some(1e9),
                fov: 1.0,
                ..Camera::default()
            },
        ] {
            for planar in [false, true] {
                let s = FrameSpec {
                    camera,
                    planar,
                    trail: &trail,
                    target: Some(&[1.0; 5]),
                    force: [1e300, f64::MAX],
                    track_limit: 1e300,
                    ..spec(&y, &lengths)
                };
                assert_eq!(draw(&s).len(), W * H * 3);
            }
        }
    }

    #[test]
    fn bad_cameras_are_refused_by_render() {
        let y = paper(&[1.0; 5]);
        let s = FrameSpec {
            camera: Camera {
                fov: 0.0,
                ..Camera::default()
            },
            ..spec(&y, &[0.1; 5])
        };
        let mut px = vec![0u8; W * H * 3];
        let e = render(W, H, &s, &mut px).unwrap_err().to_string();
        assert!(e.contains("fov") && e.contains("[1, 120]"), "{e}");
    }
}
