//! Draws the flat views of the chain: a side view (e1 right, e3 = gravity down), a
//! top view (e1 right, e2 up), or both side by side, the cart on its track (with distance marks when the
//! track scrolls with the cart), the target equilibrium drawn faintly from the cart,
//! and the applied force as an arrow.

use super::camera::Camera;
use super::canvas::{Canvas, Rgb};

const BACKGROUND: Rgb = [250, 250, 250];
const TRACK: Rgb = [150, 150, 150];
const CART: Rgb = [40, 70, 160];
const LINK: Rgb = [30, 30, 30];
const MASS: Rgb = [220, 120, 30];
const TARGET: Rgb = [110, 110, 110];
const FORCE: Rgb = [200, 30, 30];
const SEPARATOR: Rgb = [200, 200, 200];

/// What to draw. `state` is a spatial state `[x(2), xdot(2), q(3n), w(3n)]` (planar
/// states are embedded first); `target` is a sign tuple or `None`.
pub struct FrameSpec<'a> {
    /// Link lengths, m.
    pub lengths: &'a [f64],
    /// The spatial state to draw.
    pub state: &'a [f64],
    /// The target equilibrium's signs, drawn faintly.
    pub target: Option<&'a [f64]>,
    /// The force of the last step, N (drawn as an arrow).
    pub force: [f64; 2],
    /// The force that draws as 60% of the chain's length.
    pub max_force: f64,
    /// Track half-length, m (end stops; infinite: none).
    pub track_limit: f64,
    /// The state is a planar one embedded (the 3-D view draws a single rail).
    pub planar: bool,
    /// Which view to draw.
    pub view: ViewKind,
    /// The 3-D view's camera.
    pub camera: Camera,
    /// Recent positions of the tip, oldest first (model coordinates), drawn as a
    /// fading line by the 3-D view.
    pub trail: &'a [[f64; 3]],
}

/// The picture a frame shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ViewKind {
    /// A lit perspective view.
    ThreeD,
    /// The side view alone: e1 right, gravity down.
    Side,
    /// The top view alone: e1 right, e2 up, centred on the cart.
    Top,
    /// The side view with the top view beside it.
    SideTop,
}

impl ViewKind {
    /// The names of the views, as the `render_view` key takes them.
    pub const NAMES: [&'static str; 4] = ["3d", "side", "top", "side+top"];

    /// The view of a name.
    pub fn from_name(name: &str) -> crate::error::Result<Self> {
        match name {
            "3d" => Ok(Self::ThreeD),
            "side" => Ok(Self::Side),
            "top" => Ok(Self::Top),
            "side+top" => Ok(Self::SideTop),
            _ => Err(crate::error::InputError::UnknownName {
                kind: "render_view",
                name: name.to_string(),
                expected: &Self::NAMES,
            }
            .into()),
        }
    }

    /// The view's name.
    pub fn name(self) -> &'static str {
        match self {
            Self::ThreeD => "3d",
            Self::Side => "side",
            Self::Top => "top",
            Self::SideTop => "side+top",
        }
    }

    /// The view drawn unless one is chosen: the 3-D view for spatial chains, the side
    /// view (which shows a planar chain exactly) for planar ones.
    pub fn default_for(planar: bool) -> Self {
        if planar {
            Self::Side
        } else {
            Self::ThreeD
        }
    }

    fn has_side(self) -> bool {
        matches!(self, Self::Side | Self::SideTop)
    }

    fn has_top(self) -> bool {
        matches!(self, Self::Top | Self::SideTop)
    }
}

/// Maps world coordinates of one view to pixels of its panel.
struct View {
    origin: [f64; 2],
    center: [f64; 2],
    scale: f64,
    flip_y: bool,
}

impl View {
    fn px(&self, p: [f64; 2]) -> [f64; 2] {
        let dy = (p[1] - self.center[1]) * self.scale;
        [
            self.origin[0] + (p[0] - self.center[0]) * self.scale,
            self.origin[1] + if self.flip_y { -dy } else { dy },
        ]
    }
}

pub(crate) fn finite_or(v: f64, fallback: f64) -> f64 {
    if v.is_finite() {
        v
    } else {
        fallback
    }
}

/// Points of the chain from the cart: the cart, then each mass (3-D).
fn chain_points(
    cart: [f64; 2],
    lengths: &[f64],
    direction: impl Fn(usize) -> [f64; 3],
) -> Vec<[f64; 3]> {
    let mut p = [cart[0], cart[1], 0.0];
    let mut out = vec![p];
    for (i, l) in lengths.iter().enumerate() {
        let q = direction(i);
        for k in 0..3 {
            p[k] += l * q[k];
        }
        out.push(p);
    }
    out
}

/// Links as lines, masses as discs sized to the shortest link on screen so that
/// short links stay visible.
fn draw_chain(
    canvas: &mut Canvas,
    view: &View,
    points: &[[f64; 3]],
    axes: (usize, usize),
    width: f64,
    colors: (Rgb, Rgb),
    alpha: f64,
) {
    let project = |p: &[f64; 3]| view.px([p[axes.0], p[axes.1]]);
    let shortest = points
        .windows(2)
        .map(|pair| {
            (0..3)
                .map(|k| (pair[1][k] - pair[0][k]).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .fold(f64::INFINITY, f64::min);
    let radius = (0.22 * shortest * view.scale).clamp(1.5, 2.0 * width.max(1.0));
    for pair in points.windows(2) {
        canvas.capsule(project(&pair[0]), project(&pair[1]), width, colors.0, alpha);
    }
    for p in &points[1..] {
        canvas.capsule(project(p), project(p), radius, colors.1, alpha);
    }
}

fn draw_arrow(canvas: &mut Canvas, from: [f64; 2], to: [f64; 2], width: f64) {
    let (dx, dy) = (to[0] - from[0], to[1] - from[1]);
    let len = (dx * dx + dy * dy).sqrt();
    if len.is_nan() || len <= 1.0 {
        return;
    }
    canvas.capsule(from, to, width, FORCE, 1.0);
    let (ux, uy) = (dx / len, dy / len);
    let head = (3.0 * width + 4.0).min(0.5 * len);
    for side in [-1.0, 1.0] {
        let tip = [
            to[0] - head * (ux - side * 0.6 * uy),
            to[1] - head * (uy + side * 0.6 * ux),
        ];
        canvas.capsule(to, tip, width, FORCE, 1.0);
    }
}

/// The largest of 1, 2, 5 times a power of ten not above `x` (> 0).
pub(crate) fn nice_step(x: f64) -> f64 {
    let power = 10f64.powf(x.log10().floor());
    [5.0, 2.0, 1.0]
        .into_iter()
        .map(|m| m * power)
        .find(|&step| step <= x)
        .unwrap_or(power)
}

/// Short marks along a track that scrolls with the cart (every 1, 2 or 5 times a
/// power of ten metres, a taller one at the origin), so that the cart's motion shows.
fn draw_track_ticks(
    canvas: &mut Canvas,
    side: &View,
    center_x: f64,
    visible: f64,
    track: f64,
    link_width: f64,
) {
    if !(center_x.is_finite() && visible.is_finite() && visible > 0.0) {
        return;
    }
    let step = nice_step(0.5 * visible);
    // Far out, neighbouring multiples of the step are no longer distinct numbers.
    if center_x.abs() / step > 1e12 {
        return;
    }
    let first = ((center_x - visible) / step).ceil();
    let count = (((center_x + visible) / step).floor() - first).max(-1.0) as i64 + 1;
    for i in 0..count.min(64) {
        let x = (first + i as f64) * step;
        if x.abs() > track {
            continue;
        }
        let half = if x == 0.0 { 3.0 } else { 1.5 } * link_width;
        let p = side.px([x, 0.0]);
        canvas.capsule(
            [p[0], p[1] - half],
            [p[0], p[1] + half],
            0.35 * link_width,
            TRACK,
            1.0,
        );
    }
}

/// Sizes shared by both views, derived once per frame from the canvas and the spec.
struct FrameLayout {
    /// Canvas height in pixels.
    height: f64,
    /// Width of the side view's panel (the whole canvas without a top view).
    side_width: f64,
    /// Track half-length (infinite when unlimited).
    track: f64,
    /// Whether the side view follows the cart (the track is much longer than the chain).
    follow: bool,
    /// World half-width and half-height shown by the side view.
    half_width: f64,
    half_height: f64,
    /// Pixels per metre of the side view.
    scale: f64,
    chain_length: f64,
    link_width: f64,
    /// Half-extent of the cart box, in metres.
    cart_half: [f64; 2],
}

impl FrameLayout {
    fn new(canvas: &Canvas, spec: &FrameSpec) -> Self {
        let chain_length: f64 = spec.lengths.iter().sum();
        let (w, height) = (canvas.width() as f64, canvas.height() as f64);
        // The side view shows the track, so it gets the larger share of the width.
        let side_width = match spec.view {
            ViewKind::SideTop => 0.62 * w,
            ViewKind::Top => 0.0,
            _ => w,
        };
        let track = if spec.track_limit.is_finite() {
            spec.track_limit.max(0.0)
        } else {
            f64::INFINITY
        };
        // Show the whole track when it is not much longer than the chain; otherwise
        // follow the cart.
        let follow = track > 2.0 * chain_length;
        let half_width = if follow {
            1.6 * chain_length
        } else {
            track + 1.15 * chain_length
        };
        let half_height = 1.15 * chain_length;
        Self {
            height,
            side_width,
            track,
            follow,
            half_width,
            half_height,
            scale: (0.5 * side_width / half_width).min(0.5 * height / half_height),
            chain_length,
            link_width: (0.006 * height).max(0.8),
            cart_half: [0.12 * chain_length.max(1e-9), 0.05 * chain_length.max(1e-9)],
        }
    }

    /// Metres of arrow per newton: `max_force` is drawn 60% of the chain's length long.
    fn arrow_scale(&self, max_force: f64) -> f64 {
        if max_force > 0.0 {
            0.6 * self.chain_length / max_force
        } else {
            0.0
        }
    }
}

/// Draws the flat view(s) of `spec` into the whole canvas.
pub fn draw_frame(canvas: &mut Canvas, spec: &FrameSpec) {
    canvas.fill(BACKGROUND);
    let y = spec.state;
    let cart = [finite_or(y[0], 0.0), finite_or(y[1], 0.0)];
    let q = |i: usize| [y[4 + 3 * i], y[5 + 3 * i], y[6 + 3 * i]];
    let points = chain_points(cart, spec.lengths, q);
    let layout = FrameLayout::new(canvas, spec);
    // Each view draws only inside its panel (the track line or a far-off cart would
    // otherwise run on into the top view).
    let panel_columns = layout.side_width.round() as usize;
    if spec.view.has_side() {
        canvas.clip_columns(0, panel_columns);
        draw_side_view(canvas, spec, &layout, cart, &points);
    }
    if spec.view.has_top() && !spec.lengths.is_empty() {
        canvas.clip_columns(panel_columns, canvas.width());
        draw_top_view(canvas, spec, &layout, cart, &points);
    }
}

/// Side view: e1 to the right, e3 (gravity) down the screen; track, target, cart,
/// chain and the force's e1 component.
fn draw_side_view(
    canvas: &mut Canvas,
    spec: &FrameSpec,
    layout: &FrameLayout,
    cart: [f64; 2],
    points: &[[f64; 3]],
) {
    let center_x = if layout.follow { cart[0] } else { 0.0 };
    let side = View {
        origin: [0.5 * layout.side_width, 0.5 * layout.height],
        center: [center_x, 0.0],
        scale: layout.scale,
        flip_y: false,
    };
    draw_track(canvas, &side, layout, center_x);
    if let Some(s) = spec.target {
        let target = chain_points(cart, spec.lengths, |i| [0.0, 0.0, s[i]]);
        draw_chain(
            canvas,
            &side,
            &target,
            (0, 2),
            layout.link_width,
            (TARGET, TARGET),
            0.3,
        );
    }
    let c = side.px([cart[0], 0.0]);
    let (cw, ch) = (
        layout.cart_half[0] * layout.scale,
        layout.cart_half[1] * layout.scale,
    );
    canvas.rect([c[0] - cw, c[1] - ch], [c[0] + cw, c[1] + ch], CART, 1.0);
    draw_chain(
        canvas,
        &side,
        points,
        (0, 2),
        layout.link_width,
        (LINK, MASS),
        1.0,
    );
    let arrow_scale = layout.arrow_scale(spec.max_force);
    let tip = side.px([cart[0] + spec.force[0] * arrow_scale, 0.0]);
    draw_arrow(
        canvas,
        [c[0], c[1]],
        [tip[0], c[1]],
        0.6 * layout.link_width,
    );
}

/// The track line, its distance marks when the view follows the cart, and its end stops.
fn draw_track(canvas: &mut Canvas, side: &View, layout: &FrameLayout, center_x: f64) {
    let (track, link_width) = (layout.track, layout.link_width);
    let track_ends = if track.is_finite() {
        [-track, track]
    } else {
        [
            center_x - 2.0 * layout.half_width,
            center_x + 2.0 * layout.half_width,
        ]
    };
    canvas.capsule(
        side.px([track_ends[0], 0.0]),
        side.px([track_ends[1], 0.0]),
        0.5 * link_width,
        TRACK,
        1.0,
    );
    if layout.follow {
        let visible = 0.5 * layout.side_width / layout.scale;
        draw_track_ticks(canvas, side, center_x, visible, track, link_width);
    }
    if track.is_finite() {
        for end in track_ends {
            let p = side.px([end, 0.0]);
            canvas.capsule(
                [p[0], p[1] - 3.0 * link_width],
                [p[0], p[1] + 3.0 * link_width],
                0.5 * link_width,
                TRACK,
                1.0,
            );
        }
    }
}

/// Top view: e1 to the right, e2 up; the chain seen from above, centred on the cart,
/// with both force components.
fn draw_top_view(
    canvas: &mut Canvas,
    spec: &FrameSpec,
    layout: &FrameLayout,
    cart: [f64; 2],
    points: &[[f64; 3]],
) {
    let (panel_w, h) = (layout.side_width, layout.height);
    let top_w = canvas.width() as f64 - panel_w;
    if panel_w > 0.0 {
        canvas.rect([panel_w - 0.5, 0.0], [panel_w + 0.5, h], SEPARATOR, 1.0);
    }
    let top = View {
        origin: [panel_w + 0.5 * top_w, 0.5 * h],
        center: cart,
        scale: 0.5 * top_w.min(h) / layout.half_height,
        flip_y: true,
    };
    let c = top.px(cart);
    let cw = (layout.cart_half[0] * top.scale).min(0.06 * h);
    canvas.rect([c[0] - cw, c[1] - cw], [c[0] + cw, c[1] + cw], CART, 0.35);
    draw_chain(
        canvas,
        &top,
        points,
        (0, 1),
        layout.link_width,
        (LINK, MASS),
        1.0,
    );
    let arrow_scale = layout.arrow_scale(spec.max_force);
    let tip = top.px([
        cart[0] + spec.force[0] * arrow_scale,
        cart[1] + spec.force[1] * arrow_scale,
    ]);
    draw_arrow(canvas, c, tip, 0.6 * layout.link_width);
}
