//! Depth-tested, anti-aliased drawing of shaded primitives (spheres, rods, convex
//! polygons) into an RGB frame, and the frame's background: sky, a floor with a grid
//! fading into the distance, the bodies' shadows on it and the tip's trail.
//!
//! Edges are anti-aliased by coverage: each primitive blends into what is already
//! there in proportion to how much of a pixel it covers, so primitives are drawn far
//! to near; a depth buffer keeps near things in front where shapes interpenetrate
//! (a link through the cart, a rod into a sphere). Shadows and the trail are drawn
//! into coverage masks first (the maximum of overlapping shapes, so overlaps do not
//! darken twice) and composited by the background pass.

use super::camera::{dot, Projection, ScreenPoint};

/// A colour with components in 0..=255.
pub type Color = [f32; 3];

/// A rectangle of pixels `[x0, x1) x [y0, y1)`, empty when `x0 >= x1`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Rect {
    x0: usize,
    y0: usize,
    x1: usize,
    y1: usize,
}

impl Rect {
    const EMPTY: Rect = Rect {
        x0: usize::MAX,
        y0: usize::MAX,
        x1: 0,
        y1: 0,
    };

    fn include(&mut self, xs: std::ops::Range<usize>, y: usize) {
        self.x0 = self.x0.min(xs.start);
        self.x1 = self.x1.max(xs.end);
        self.y0 = self.y0.min(y);
        self.y1 = self.y1.max(y + 1);
    }

    fn rows(&self) -> std::ops::Range<usize> {
        if self.x0 >= self.x1 {
            0..0
        } else {
            self.y0..self.y1
        }
    }
}

/// Buffers reused from frame to frame: the depth buffer and the two coverage masks,
/// each with the rectangle the last frame touched (only that is cleared).
#[derive(Debug, Default)]
pub struct Scratch {
    width: usize,
    height: usize,
    depth: Vec<f32>,
    depth_touched: Rect,
    shadow: Vec<u8>,
    shadow_touched: Rect,
    trail: Vec<u8>,
    trail_touched: Rect,
    rows: Vec<FloorRow>,
    /// One row of grid-line coverage, and the column ranges the lines reach.
    cover: Vec<f32>,
    spans: Vec<(usize, usize)>,
}

impl Default for Rect {
    fn default() -> Self {
        Rect::EMPTY
    }
}

fn reset<T: Copy>(buffer: &mut [T], width: usize, touched: &mut Rect, value: T) {
    for y in touched.rows() {
        buffer[y * width + touched.x0..y * width + touched.x1].fill(value);
    }
    *touched = Rect::EMPTY;
}

impl Scratch {
    /// Prepares the buffers for a frame of `width x height`: cleared where the last
    /// frame drew.
    fn begin(&mut self, width: usize, height: usize) {
        if (self.width, self.height) != (width, height) {
            let n = width * height;
            *self = Scratch {
                width,
                height,
                depth: vec![f32::INFINITY; n],
                shadow: vec![0; n],
                trail: vec![0; n],
                rows: Vec::with_capacity(height),
                ..Scratch::default()
            };
        }
        reset(
            &mut self.depth,
            width,
            &mut self.depth_touched,
            f32::INFINITY,
        );
        reset(&mut self.shadow, width, &mut self.shadow_touched, 0);
        reset(&mut self.trail, width, &mut self.trail_touched, 0);
    }
}

/// How bodies are lit: a light from above and behind the camera's left shoulder,
/// in camera coordinates `(right, up, depth)`.
#[derive(Debug, Clone, Copy)]
struct Light {
    direction: [f32; 3],
    half_vector: [f32; 3],
}

const AMBIENT: f32 = 0.38;
const DIFFUSE: f32 = 0.62;
const SPECULAR: f32 = 0.35;

impl Light {
    fn new() -> Self {
        let normalize = |v: [f32; 3]| {
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            [v[0] / n, v[1] / n, v[2] / n]
        };
        let direction = normalize([-0.45, 0.7, -0.55]);
        let half_vector = normalize([direction[0], direction[1], direction[2] - 1.0]);
        Self {
            direction,
            half_vector,
        }
    }

    /// The colour of a surface of `base` colour with unit normal `n` (camera coordinates).
    #[inline]
    fn shade(&self, base: Color, n: [f32; 3]) -> Color {
        let lambert =
            (n[0] * self.direction[0] + n[1] * self.direction[1] + n[2] * self.direction[2])
                .max(0.0);
        let h =
            (n[0] * self.half_vector[0] + n[1] * self.half_vector[1] + n[2] * self.half_vector[2])
                .max(0.0);
        let h2 = h * h;
        let h8 = h2 * h2 * h2 * h2;
        let glint = SPECULAR * 255.0 * h8 * h8 * h8;
        let k = AMBIENT + DIFFUSE * lambert;
        [
            (base[0] * k + glint).min(255.0),
            (base[1] * k + glint).min(255.0),
            (base[2] * k + glint).min(255.0),
        ]
    }

    /// A flat face's shade: normal `n` given in camera coordinates.
    pub fn flat(&self, base: Color, n: [f64; 3]) -> Color {
        self.shade(base, [n[0] as f32, n[1] as f32, n[2] as f32])
    }
}

/// How a primitive is drawn: its opacity and whether it hides what is drawn later
/// behind it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Paint {
    /// Base colour (before shading).
    pub color: Color,
    /// Opacity in [0, 1].
    pub alpha: f32,
    /// Writes depth where it covers most of a pixel (translucent ghosts do not).
    pub solid: bool,
}

/// The floor, as the background pass and the shadows see it.
#[derive(Debug, Clone, Copy)]
pub struct Floor {
    /// Height of the floor plane (z-up frame, relative to the anchor), m.
    pub height: f64,
    /// Grid spacing, m.
    pub spacing: f64,
    /// Anchor's offset from the nearest grid corner, m (grid lines sit at
    /// `offset + k spacing` in the anchor frame... negated).
    pub offset: [f64; 2],
    /// Distance over which the floor fades into the horizon's colour, m.
    pub fog: f64,
}

/// Floor coordinates of one pixel row: `p(x) = p0 + x dp` (the floor point under
/// pixel column `x`, as `[e1, e2]` from the grid origin), its depth, and the
/// derivative of `p` down the rows, `dpdy0 + x dpdy_dx`.
#[derive(Debug, Clone, Copy, Default)]
struct FloorRow {
    depth: f64,
    p0: [f64; 2],
    dp: [f64; 2],
    dpdy0: [f64; 2],
    dpdy_dx: [f64; 2],
    /// Sky brightness parameter: the ray's upward slope.
    rise: f64,
}

const SKY_ZENITH: Color = [214.0, 226.0, 242.0];
const SKY_HORIZON: Color = [238.0, 240.0, 243.0];
const FLOOR: Color = [232.0, 231.0, 226.0];
const GRID: Color = [188.0, 188.0, 184.0];
const SHADOW: Color = [150.0, 150.0, 148.0];

/// An RGB frame being drawn, with its depth buffer and masks.
pub struct Raster<'a> {
    width: usize,
    height: usize,
    rgb: &'a mut [u8],
    scratch: &'a mut Scratch,
    light: Light,
}

/// `x` such that `lo <= slope x + offset <= hi` (all `x` when the slope is 0 and the
/// offset lies in range), as `(from, to)`; `None` when empty.
fn linear_interval(slope: f64, offset: f64, lo: f64, hi: f64) -> Option<(f64, f64)> {
    if slope.abs() < 1e-12 {
        return (lo <= offset && offset <= hi).then_some((f64::NEG_INFINITY, f64::INFINITY));
    }
    let (a, b) = ((lo - offset) / slope, (hi - offset) / slope);
    Some((a.min(b), a.max(b)))
}

fn intersect(a: (f64, f64), b: (f64, f64)) -> Option<(f64, f64)> {
    let r = (a.0.max(b.0), a.1.min(b.1));
    (r.0 <= r.1).then_some(r)
}

fn hull(a: Option<(f64, f64)>, b: Option<(f64, f64)>) -> Option<(f64, f64)> {
    match (a, b) {
        (Some(a), Some(b)) => Some((a.0.min(b.0), a.1.max(b.1))),
        (a, None) => a,
        (None, b) => b,
    }
}

/// The parameters `t` for which the point `origin + t dir` lies within `reach` of
/// the segment `a`-`b`: one interval (a capsule is convex), the hull of where the
/// line meets the two end discs and the slab between them.
fn capsule_interval(
    origin: [f64; 2],
    dir: [f64; 2],
    a: [f64; 2],
    b: [f64; 2],
    reach: f64,
) -> Option<(f64, f64)> {
    let disc = |c: [f64; 2]| {
        // |origin - c + t dir|^2 <= reach^2
        let (ox, oy) = (origin[0] - c[0], origin[1] - c[1]);
        let qa = dir[0] * dir[0] + dir[1] * dir[1];
        let qb = ox * dir[0] + oy * dir[1];
        let qc = ox * ox + oy * oy - reach * reach;
        let disc = qb * qb - qa * qc;
        (qa > 0.0 && disc >= 0.0).then(|| {
            let root = disc.sqrt();
            ((-qb - root) / qa, (-qb + root) / qa)
        })
    };
    let mut span = hull(disc(a), disc(b));
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    if len2 > 0.0 {
        let (ox, oy) = (origin[0] - a[0], origin[1] - a[1]);
        let along = linear_interval(dir[0] * dx + dir[1] * dy, ox * dx + oy * dy, 0.0, len2);
        let reach_len = reach * len2.sqrt();
        let across = linear_interval(
            dx * dir[1] - dy * dir[0],
            dx * oy - dy * ox,
            -reach_len,
            reach_len,
        );
        if let (Some(p), Some(q)) = (along, across) {
            span = hull(span, intersect(p, q));
        }
    }
    span
}

/// The columns of a disc of radius `r` about `(cx, cy)` on the row whose centres lie
/// at height `py`.
fn disc_interval(cx: f64, cy: f64, r: f64, py: f64) -> Option<(f64, f64)> {
    let h2 = r * r - (py - cy) * (py - cy);
    (h2 >= 0.0).then(|| {
        let h = h2.sqrt();
        (cx - h, cx + h)
    })
}

/// The pixel range `[from, to)` of columns whose centres lie in `[a, b]`, clipped
/// to `[0, limit)`.
fn pixel_span(a: f64, b: f64, limit: usize) -> std::ops::Range<usize> {
    if a.is_nan() || b.is_nan() || b < 0.0 || a > limit as f64 || a > b {
        return 0..0;
    }
    let from = (a - 0.5).ceil().max(0.0) as usize;
    let to = ((b - 0.5).floor() + 1.0).clamp(0.0, limit as f64) as usize;
    from.min(to)..to
}

/// Round to the nearest integer by the float trick (exact for |x| < 2^51), so that
/// the grid loop needs no call to a rounding function.
#[inline]
fn round_fast(x: f64) -> f64 {
    const MAGIC: f64 = 6755399441055744.0; // 1.5 * 2^52
    (x + MAGIC) - MAGIC
}

#[inline]
fn blend_pixel(px: &mut [u8], color: Color, a: f32) {
    for k in 0..3 {
        let c = px[k] as f32;
        px[k] = (c + a * (color[k] - c) + 0.5) as u8;
    }
}

impl<'a> Raster<'a> {
    /// Starts a frame of `width x height` pixels in `rgb` (every pixel is written by
    /// [`Raster::background`]).
    pub fn new(width: usize, height: usize, rgb: &'a mut [u8], scratch: &'a mut Scratch) -> Self {
        debug_assert_eq!(rgb.len(), width * height * 3);
        scratch.begin(width, height);
        Self {
            width,
            height,
            rgb,
            scratch,
            light: Light::new(),
        }
    }

    /// The shade of a flat face of colour `base` with camera-space normal `n`.
    pub fn face_color(&self, base: Color, n: [f64; 3]) -> Color {
        self.light.flat(base, n)
    }

    /// Computes the floor coordinates of every row (called once per frame, before the
    /// shadows and the background).
    #[inline(never)]
    pub fn map_floor(&mut self, projection: &Projection, floor: &Floor) {
        let p = projection;
        let f = p.focal;
        let rows = &mut self.scratch.rows;
        rows.clear();
        let above = p.eye[2] > floor.height;
        for y in 0..self.height {
            let v = (y as f64 + 0.5 - p.center[1]) / f;
            // Ray through (x, y): forward + ((x + 0.5 - cx) / f) right - v up.
            let base = [
                p.forward[0] - v * p.up[0] - (p.center[0] - 0.5) / f * p.right[0],
                p.forward[1] - v * p.up[1] - (p.center[0] - 0.5) / f * p.right[1],
                p.forward[2] - v * p.up[2],
            ];
            let rise = base[2];
            let mut row = FloorRow {
                rise,
                ..FloorRow::default()
            };
            if above && rise < -1e-9 {
                // Depth along forward of the floor point equals the ray parameter.
                let t = (floor.height - p.eye[2]) / rise;
                let ray_grad = p.up[2] / (f * rise); // d(t)/dy / t
                let axis = |k: usize| t * ray_grad * p.right[k] / f;
                row.p0 = [0, 1].map(|k| p.eye[k] + floor.offset[k] + t * base[k]);
                row.dp = [0, 1].map(|k| t * p.right[k] / f);
                row.dpdy0 = [0, 1].map(|k| t * (ray_grad * base[k] - p.up[k] / f));
                row.dpdy_dx = [0, 1].map(axis);
                row.depth = t;
            }
            rows.push(row);
        }
    }

    /// Adds a soft shadow to the shadow mask: the set of floor points within `radius`
    /// of the segment `a`-`b` (floor coordinates, grid origin), blurred over `blur`
    /// metres either side of its edge, at most `strength` dark. `screen` bounds the
    /// pixels it can reach.
    #[inline(never)]
    pub fn shadow(
        &mut self,
        a: [f64; 2],
        b: [f64; 2],
        radius: f64,
        blur: f64,
        strength: f32,
        screen: [f64; 4],
    ) {
        let (w, h) = (self.width, self.height);
        let ys = pixel_span(screen[1], screen[3], h);
        let xs = pixel_span(screen[0], screen[2], w);
        if xs.is_empty() || !(radius.is_finite() && blur > 0.0) {
            return;
        }
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let len2 = dx * dx + dy * dy;
        let reach = radius + blur;
        let mut touched = self.scratch.shadow_touched;
        for y in ys {
            let r = self.scratch.rows[y];
            if r.depth <= 0.0 {
                continue;
            }
            let Some((from, to)) = capsule_interval(r.p0, r.dp, a, b, reach) else {
                continue;
            };
            // Column x has its centre at x + 0.5: shift the interval found for x.
            let span = pixel_span(from + 0.5, to + 0.5, w);
            let span = span.start.max(xs.start)..span.end.min(xs.end);
            if span.is_empty() {
                continue;
            }
            for x in span.clone() {
                let xc = x as f64;
                let (qx, qy) = (r.p0[0] + xc * r.dp[0] - a[0], r.p0[1] + xc * r.dp[1] - a[1]);
                let t = if len2 > 0.0 {
                    ((qx * dx + qy * dy) / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let (ex, ey) = (qx - t * dx, qy - t * dy);
                let d = (ex * ex + ey * ey).sqrt();
                if d >= reach {
                    continue;
                }
                let cover = (((reach - d) / (2.0 * blur)).min(1.0) as f32 * strength * 255.0) as u8;
                let m = &mut self.scratch.shadow[y * w + x];
                *m = (*m).max(cover);
            }
            touched.include(span, y);
        }
        self.scratch.shadow_touched = touched;
    }

    /// Adds a screen-space stroke to the trail mask: a round-ended line of `radius`
    /// pixels from `a` to `b`, at opacity `strength`.
    #[inline(never)]
    pub fn trail_stroke(&mut self, a: [f64; 2], b: [f64; 2], radius: f64, strength: f32) {
        let w = self.width;
        let (trail, touched) = (&mut self.scratch.trail, &mut self.scratch.trail_touched);
        capsule_coverage(a, b, radius, self.width, self.height, |x, y, cover, _| {
            let m = &mut trail[y * w + x];
            *m = (*m).max((cover * strength * 255.0) as u8);
            touched.include(x..x + 1, y);
        });
    }

    /// Paints every pixel: the sky, or the floor with its grid, fog and shadows; then
    /// the trail over both.
    #[inline(never)]
    pub fn background(&mut self, floor: &Floor, trail_color: Color) {
        let (w, h) = (self.width, self.height);
        let shadow_rect = self.scratch.shadow_touched;
        let trail_rect = self.scratch.trail_touched;
        let mut cover = std::mem::take(&mut self.scratch.cover);
        cover.clear();
        cover.resize(w, 0.0);
        let mut spans = std::mem::take(&mut self.scratch.spans);
        for y in 0..h {
            let r = self.scratch.rows[y];
            let line = &mut self.rgb[3 * y * w..3 * (y + 1) * w];
            if r.depth > 0.0 {
                let fog = (1.0 - (-r.depth / floor.fog).exp()) as f32;
                let ground = mix(FLOOR, SKY_HORIZON, fog);
                let grid = mix(GRID, SKY_HORIZON, fog);
                grid_row(
                    line,
                    &mut cover,
                    &mut spans,
                    &r,
                    ground,
                    grid,
                    floor.spacing,
                );
                if shadow_rect.rows().contains(&y) {
                    let shade = mix(SHADOW, SKY_HORIZON, fog);
                    let mask = &self.scratch.shadow[y * w..(y + 1) * w];
                    for x in shadow_rect.x0..shadow_rect.x1 {
                        if mask[x] > 0 {
                            blend_pixel(&mut line[3 * x..3 * x + 3], shade, mask[x] as f32 / 255.0);
                        }
                    }
                }
            } else {
                let up = (r.rise / (1.0 + r.rise * r.rise).sqrt()).clamp(0.0, 1.0) as f32;
                fill_row(line, mix(SKY_HORIZON, SKY_ZENITH, (2.5 * up).min(1.0)));
            }
            if trail_rect.rows().contains(&y) {
                let mask = &self.scratch.trail[y * w..(y + 1) * w];
                for x in trail_rect.x0..trail_rect.x1 {
                    if mask[x] > 0 {
                        blend_pixel(
                            &mut line[3 * x..3 * x + 3],
                            trail_color,
                            mask[x] as f32 / 255.0,
                        );
                    }
                }
            }
        }
        self.scratch.cover = cover;
        self.scratch.spans = spans;
    }

    /// Where fragments go: the frame, the depth buffer and the rectangle they touch.
    fn target(&mut self) -> Target<'_> {
        Target {
            width: self.width,
            rgb: self.rgb,
            depth: &mut self.scratch.depth,
            touched: &mut self.scratch.depth_touched,
        }
    }

    /// A lit sphere of `radius_px` pixels (`radius` metres) centred on `c`.
    #[inline(never)]
    pub fn sphere(&mut self, c: ScreenPoint, radius_px: f64, radius: f64, paint: &Paint) {
        let reach = radius_px + 1.0;
        let ys = pixel_span(c.y - reach, c.y + reach, self.height);
        let inv = 1.0 / radius_px.max(1e-9);
        for y in ys {
            let py = y as f64 + 0.5;
            let Some((a, b)) = disc_interval(c.x, c.y, reach, py) else {
                continue;
            };
            let xs = pixel_span(a, b, self.width);
            let light = self.light;
            let mut target = self.target();
            target.touched.include(xs.clone(), y);
            let dy = py - c.y;
            for x in xs {
                let dx = x as f64 + 0.5 - c.x;
                let d = (dx * dx + dy * dy).sqrt();
                let cover = (radius_px + 0.5 - d).clamp(0.0, 1.0) as f32;
                if cover <= 0.0 {
                    continue;
                }
                let s = (d * inv).min(1.0);
                let nz = (1.0 - s * s).sqrt();
                let n = [(dx * inv) as f32, (-dy * inv) as f32, -nz as f32];
                let color = light.shade(paint.color, n);
                target.fragment(x, y, (c.z - radius * nz) as f32, color, cover, paint);
            }
        }
    }

    /// A lit rod (a capsule: a cylinder with round ends) of `radius_px` pixels
    /// (`radius` metres) from `a` to `b`.
    #[inline(never)]
    pub fn rod(
        &mut self,
        a: ScreenPoint,
        b: ScreenPoint,
        radius_px: f64,
        radius: f64,
        paint: &Paint,
    ) {
        let inv = 1.0 / radius_px.max(1e-9);
        let light = self.light;
        let (width, height) = (self.width, self.height);
        // Across the rod's body the shade depends only on the signed offset from its
        // axis: a table of it, looked up per pixel (the round ends are shaded exactly).
        let (dx, dy) = (b.x - a.x, b.y - a.y);
        let len = dx.hypot(dy).max(1e-12);
        let across = [-dy / len, dx / len];
        let table: [(Color, f64); ROD_SHADES] = std::array::from_fn(|i| {
            let s = -1.0 + 2.0 * i as f64 / (ROD_SHADES - 1) as f64;
            let nz = (1.0 - s * s).max(0.0).sqrt();
            let n = [(s * across[0]) as f32, (-s * across[1]) as f32, -nz as f32];
            (light.shade(paint.color, n), nz)
        });
        let to_index = 0.5 * (ROD_SHADES - 1) as f64;
        let reach = radius_px + 1.0;
        let xs = pixel_span(a.x.min(b.x) - reach, a.x.max(b.x) + reach, width);
        let ys = pixel_span(a.y.min(b.y) - reach, a.y.max(b.y) + reach, height);
        let mut target = self.target();
        if !xs.is_empty() && !ys.is_empty() {
            target.touched.include(xs.clone(), ys.start);
            target.touched.include(xs, ys.end - 1);
        }
        capsule_coverage(
            [a.x, a.y],
            [b.x, b.y],
            radius_px,
            width,
            height,
            |x, y, cover, (t, ex, ey)| {
                let (color, nz) = if t > 0.0 && t < 1.0 {
                    let s = ((ex * across[0] + ey * across[1]) * inv).clamp(-1.0, 1.0);
                    table[((s + 1.0) * to_index + 0.5) as usize]
                } else {
                    let s = ((ex * ex + ey * ey).sqrt() * inv).min(1.0);
                    let nz = (1.0 - s * s).sqrt();
                    let n = [(ex * inv) as f32, (-ey * inv) as f32, -nz as f32];
                    (light.shade(paint.color, n), nz)
                };
                let z = a.z + t * (b.z - a.z) - radius * nz;
                target.fragment(x, y, z as f32, color, cover, paint);
            },
        );
    }

    /// A flat convex polygon of colour `color` (already shaded). `vertices` in order
    /// around it; edge `i` runs from vertex `i` to `i + 1` and is anti-aliased unless
    /// `inner_edges[i]` (an edge shared with a neighbouring face, drawn hard so that
    /// no background shows through the seam).
    #[inline(never)]
    pub fn polygon(
        &mut self,
        vertices: &[ScreenPoint],
        inner_edges: &[bool],
        color: Color,
        paint: &Paint,
    ) {
        let n = vertices.len();
        if n < 3
            || vertices
                .iter()
                .any(|v| !(v.x.is_finite() && v.y.is_finite()))
        {
            return;
        }
        let area: f64 = (0..n)
            .map(|i| {
                let (p, q) = (vertices[i], vertices[(i + 1) % n]);
                p.x * q.y - q.x * p.y
            })
            .sum();
        if area.abs() < 1e-9 {
            return;
        }
        let sign = area.signum();
        // Inside: n . p + c >= 0 for every edge, with n a unit normal.
        let edges: Vec<([f64; 2], f64, bool)> = (0..n)
            .map(|i| {
                let (p, q) = (vertices[i], vertices[(i + 1) % n]);
                let (dx, dy) = (q.x - p.x, q.y - p.y);
                let len = (dx * dx + dy * dy).sqrt().max(1e-12);
                let normal = [-dy * sign / len, dx * sign / len];
                let c = -(normal[0] * p.x + normal[1] * p.y);
                (normal, c, inner_edges.get(i).copied().unwrap_or(false))
            })
            .collect();
        let Some(inverse_depth) = inverse_depth_plane(vertices) else {
            return;
        };
        let (ymin, ymax) = vertices
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v.y), hi.max(v.y))
            });
        for y in pixel_span(ymin - 1.5, ymax + 1.5, self.height) {
            let py = y as f64 + 0.5;
            let mut span = Some((f64::NEG_INFINITY, f64::INFINITY));
            for &(normal, c, _) in &edges {
                span = span.and_then(|s| {
                    linear_interval(normal[0], normal[1] * py + c, -0.5, f64::INFINITY)
                        .and_then(|e| intersect(s, e))
                });
            }
            let Some((from, to)) = span else {
                continue;
            };
            let xs = pixel_span(from, to, self.width);
            let mut target = self.target();
            target.touched.include(xs.clone(), y);
            for x in xs {
                let px = x as f64 + 0.5;
                let cover = edges
                    .iter()
                    .map(|&(normal, c, inner)| {
                        // Inner edges are hard: every pixel whose centre lies within
                        // half a pixel of the face is fully covered, so that the
                        // neighbouring face meets it without a seam.
                        let e = normal[0] * px + normal[1] * py + c + 0.5;
                        if inner {
                            if e >= 0.0 {
                                1.0
                            } else {
                                0.0
                            }
                        } else {
                            e
                        }
                    })
                    .fold(1.0f64, f64::min)
                    .clamp(0.0, 1.0) as f32;
                if cover <= 0.0 {
                    continue;
                }
                let z = 1.0 / (inverse_depth[0] * px + inverse_depth[1] * py + inverse_depth[2]);
                target.fragment(x, y, z as f32, color, cover, paint);
            }
        }
    }
}

/// Where fragments go (see [`Raster::target`]).
struct Target<'b> {
    width: usize,
    rgb: &'b mut [u8],
    depth: &'b mut [f32],
    touched: &'b mut Rect,
}

impl Target<'_> {
    /// Blends one fragment at `(x, y)` of depth `z`: hidden behind a nearer solid
    /// fragment, else mixed in by `cover * alpha`; solid fragments covering most of
    /// the pixel take its depth.
    #[inline]
    fn fragment(&mut self, x: usize, y: usize, z: f32, color: Color, cover: f32, paint: &Paint) {
        let i = y * self.width + x;
        // A little slack, so that faces meeting at an edge both reach it.
        if z > self.depth[i] * (1.0 + DEPTH_SLACK) {
            return;
        }
        let a = cover * paint.alpha;
        let px = &mut self.rgb[3 * i..3 * i + 3];
        if a >= 1.0 {
            px[0] = (color[0] + 0.5) as u8;
            px[1] = (color[1] + 0.5) as u8;
            px[2] = (color[2] + 0.5) as u8;
        } else {
            blend_pixel(px, color, a);
        }
        if paint.solid && a >= 0.5 {
            self.depth[i] = z;
        }
    }
}

/// `1 / z = a x + b y + c` through the polygon's first three vertices (`1 / z` is
/// affine on screen for a flat face).
fn inverse_depth_plane(v: &[ScreenPoint]) -> Option<[f64; 3]> {
    let (p, q, r) = (v[0], v[1], v[2]);
    let (wp, wq, wr) = (1.0 / p.z, 1.0 / q.z, 1.0 / r.z);
    let det = (q.x - p.x) * (r.y - p.y) - (r.x - p.x) * (q.y - p.y);
    if det.abs() < 1e-12 {
        return Some([0.0, 0.0, wp]);
    }
    let a = ((wq - wp) * (r.y - p.y) - (wr - wp) * (q.y - p.y)) / det;
    let b = ((q.x - p.x) * (wr - wp) - (r.x - p.x) * (wq - wp)) / det;
    let plane = [a, b, wp - a * p.x - b * p.y];
    plane.iter().all(|v| v.is_finite()).then_some(plane)
}

/// Calls `visit(x, y, coverage, (t, ex, ey))` for every pixel a capsule of `radius`
/// pixels from `a` to `b` covers: `t` in [0, 1] is the nearest point of the axis,
/// `(ex, ey)` the pixel centre's offset from it.
fn capsule_coverage(
    a: [f64; 2],
    b: [f64; 2],
    radius: f64,
    width: usize,
    height: usize,
    mut visit: impl FnMut(usize, usize, f32, (f64, f64, f64)),
) {
    if !(a.iter().chain(&b).all(|v| v.is_finite()) && radius.is_finite() && radius > 0.0) {
        return;
    }
    let reach = radius + 1.0;
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    let ys = pixel_span(a[1].min(b[1]) - reach, a[1].max(b[1]) + reach, height);
    for y in ys {
        let py = y as f64 + 0.5;
        let span = capsule_interval([0.0, py], [1.0, 0.0], a, b, reach);
        let Some((from, to)) = span else {
            continue;
        };
        for x in pixel_span(from, to, width) {
            let (cx, cy) = (x as f64 + 0.5 - a[0], py - a[1]);
            let t = if len2 > 0.0 {
                ((cx * dx + cy * dy) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let (ex, ey) = (cx - t * dx, cy - t * dy);
            let cover = (radius + 0.5 - (ex * ex + ey * ey).sqrt()).clamp(0.0, 1.0) as f32;
            if cover > 0.0 {
                visit(x, y, cover, (t, ex, ey));
            }
        }
    }
}

fn mix(a: Color, b: Color, t: f32) -> Color {
    [
        a[0] + t * (b[0] - a[0]),
        a[1] + t * (b[1] - a[1]),
        a[2] + t * (b[2] - a[2]),
    ]
}

/// Relative depth within which a fragment is not hidden by a nearer one.
const DEPTH_SLACK: f32 = 1e-4;

/// Shades tabulated across a rod.
const ROD_SHADES: usize = 33;

/// Grid lines fade out where cells are fewer than this many pixels across...
const GRID_FADE_FROM: f64 = 16.0;
/// ... and are fully drawn from this many more.
const GRID_FADE_OVER: f64 = 16.0;

/// One floor row: the ground colour with the grid's lines, each about one pixel
/// wide however far, faded out where they crowd closer than a few pixels. Only the
/// pixels near a line are visited: each line crosses the row at one column.
#[inline(never)]
fn grid_row(
    line: &mut [u8],
    cover: &mut [f32],
    spans: &mut Vec<(usize, usize)>,
    r: &FloorRow,
    ground: Color,
    grid: Color,
    spacing: f64,
) {
    let width = line.len() / 3;
    fill_row(line, ground);
    let (w, inv_spacing) = (width as f64, 1.0 / spacing);
    spans.clear();
    for k in 0..2 {
        // Pixels per grid cell at this row (the footprint of a pixel varies little
        // along a row: interpolated between its ends).
        let cells = |x: f64| {
            spacing
                / (r.dp[k] * r.dp[k] + (r.dpdy0[k] + x * r.dpdy_dx[k]).powi(2))
                    .sqrt()
                    .max(1e-300)
        };
        let (c0, c1) = (cells(0.0), cells(w));
        if c0.max(c1) <= GRID_FADE_FROM {
            continue;
        }
        let cell_px = |x: f64| c0 + (x / w) * (c1 - c0);
        let coverage = |x: f64| {
            let s = (r.p0[k] + x * r.dp[k]) * inv_spacing;
            let c = cell_px(x);
            let fade = ((c - GRID_FADE_FROM) * (1.0 / GRID_FADE_OVER)).clamp(0.0, 1.0);
            ((1.0 - (s - round_fast(s)).abs() * c).max(0.0) * fade) as f32
        };
        // Cells advanced per pixel along the row; a line is within one pixel (in its
        // own footprint) over `half_band` columns either side of its crossing, and
        // its coverage falls linearly to zero across them.
        let rate = r.dp[k] * inv_spacing;
        let half_band = |x: f64| 1.0 / (rate.abs() * cell_px(x)).max(1e-300);
        if half_band(0.5 * w) > 0.25 * w {
            // Lines nearly along the row: every pixel is near the same line.
            for (x, c) in cover.iter_mut().enumerate() {
                *c = c.max(coverage(x as f64));
            }
            spans.push((0, width));
            continue;
        }
        let (s0, s1) = (r.p0[k] * inv_spacing, (r.p0[k] + w * r.dp[k]) * inv_spacing);
        let (first, last) = (round_fast(s0.min(s1)) - 1.0, round_fast(s0.max(s1)) + 1.0);
        if !(first.is_finite() && last.is_finite()) || last - first > w {
            continue;
        }
        // Per line: where it crosses the row, how strongly it shows (fading where
        // cells are small) and over how many columns.
        let (inv_dp, slope_c) = (1.0 / r.dp[k], (c1 - c0) / w);
        let inv_rate = 1.0 / rate.abs();
        let mut m = first;
        while m <= last {
            let crossing = (m * spacing - r.p0[k]) * inv_dp;
            m += 1.0;
            let c = c0 + crossing.clamp(0.0, w) * slope_c;
            let strength = ((c - GRID_FADE_FROM) * (1.0 / GRID_FADE_OVER)).min(1.0);
            if strength.is_nan() || strength <= 0.0 {
                continue;
            }
            let band = inv_rate / c;
            let (lo, hi) = (
                (crossing - band + 0.5).max(0.0),
                (crossing + band + 0.5).min(w),
            );
            if lo >= hi {
                continue;
            }
            let (from, to) = (lo as usize, (hi as usize + 1).min(width));
            let (strength, slope, crossing) =
                (strength as f32, (1.0 / band) as f32, crossing as f32);
            for (x, cell) in cover[from..to].iter_mut().enumerate() {
                let v = (1.0 - ((from + x) as f32 - crossing).abs() * slope).max(0.0) * strength;
                *cell = cell.max(v);
            }
            spans.push((from, to));
        }
    }
    // Each pixel a line reached, once (its coverage is the maximum over the lines
    // and is cleared when used, so overlapping bands do not blend twice).
    let delta = [
        grid[0] - ground[0],
        grid[1] - ground[1],
        grid[2] - ground[2],
    ];
    for &(from, to) in spans.iter() {
        for x in from..to {
            let a = std::mem::take(&mut cover[x]);
            if a > 0.0 {
                let px = &mut line[3 * x..3 * x + 3];
                px[0] = (ground[0] + a * delta[0] + 0.5) as u8;
                px[1] = (ground[1] + a * delta[1] + 0.5) as u8;
                px[2] = (ground[2] + a * delta[2] + 0.5) as u8;
            }
        }
    }
}

/// Paints a row of pixels one colour (copying a block of pixels, doubling).
fn fill_row(line: &mut [u8], color: Color) {
    let c = [
        color[0].round() as u8,
        color[1].round() as u8,
        color[2].round() as u8,
    ];
    let head = line.len().min(48);
    for px in line[..head].chunks_exact_mut(3) {
        px.copy_from_slice(&c);
    }
    let mut filled = head;
    while filled < line.len() {
        let n = filled.min(line.len() - filled);
        line.copy_within(0..n, filled);
        filled += n;
    }
}

/// The screen bounding box `[x0, y0, x1, y1]` of floor-level points, or the whole
/// frame below the horizon when one of them is behind the camera.
pub fn screen_box(
    projection: &Projection,
    points: &[[f64; 3]],
    width: usize,
    height: usize,
) -> [f64; 4] {
    let mut b = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    for &p in points {
        match projection.project(p) {
            Some(s) => {
                b = [b[0].min(s.x), b[1].min(s.y), b[2].max(s.x), b[3].max(s.y)];
            }
            None => return [0.0, 0.0, width as f64, height as f64],
        }
    }
    b
}

/// Whether a face with outward normal `n` through point `p` faces the camera.
pub fn faces_camera(projection: &Projection, p: [f64; 3], n: [f64; 3]) -> bool {
    dot(super::camera::sub(p, projection.eye), n) < 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn paint(color: Color) -> Paint {
        Paint {
            color,
            alpha: 1.0,
            solid: true,
        }
    }

    fn blank(w: usize, h: usize) -> Vec<u8> {
        vec![255u8; w * h * 3]
    }

    fn at(px: &[u8], w: usize, x: usize, y: usize) -> [u8; 3] {
        [
            px[3 * (y * w + x)],
            px[3 * (y * w + x) + 1],
            px[3 * (y * w + x) + 2],
        ]
    }

    #[test]
    fn a_near_sphere_hides_a_far_one_whatever_the_order() {
        // Two spheres at the same pixel: red 2 m deep, blue 1 m deep. Drawn in either
        // order, the centre pixel is blue-dominated.
        for near_first in [false, true] {
            let mut px = blank(40, 40);
            let mut scratch = Scratch::default();
            let mut r = Raster::new(40, 40, &mut px, &mut scratch);
            let far = ScreenPoint {
                x: 20.0,
                y: 20.0,
                z: 2.0,
            };
            let near = ScreenPoint { z: 1.0, ..far };
            let (red, blue) = ([220.0, 0.0, 0.0], [0.0, 0.0, 220.0]);
            if near_first {
                r.sphere(near, 8.0, 0.1, &paint(blue));
                r.sphere(far, 12.0, 0.1, &paint(red));
            } else {
                r.sphere(far, 12.0, 0.1, &paint(red));
                r.sphere(near, 8.0, 0.1, &paint(blue));
            }
            let c = at(&px, 40, 20, 20);
            assert!(c[2] > 100 && c[0] < 30, "{c:?}");
            // Outside the near sphere but inside the far one: red.
            let ring = at(&px, 40, 20 + 10, 20);
            assert!(ring[0] > 60 && ring[2] < 30, "{ring:?}");
        }
    }

    #[test]
    fn edges_are_anti_aliased() {
        let mut px = blank(40, 40);
        let mut scratch = Scratch::default();
        let mut r = Raster::new(40, 40, &mut px, &mut scratch);
        r.rod(
            ScreenPoint {
                x: 5.0,
                y: 5.0,
                z: 1.0,
            },
            ScreenPoint {
                x: 35.0,
                y: 30.0,
                z: 1.0,
            },
            3.0,
            0.01,
            &paint([0.0, 0.0, 0.0]),
        );
        // Some pixels are neither the background nor fully covered: partial coverage.
        let greys = px
            .chunks_exact(3)
            .filter(|p| p[0] > 40 && p[0] < 215)
            .count();
        let dark = px.chunks_exact(3).filter(|p| p[0] < 100).count();
        assert!(greys > 20 && dark > 100, "{greys} {dark}");
    }

    #[test]
    fn a_polygon_is_filled_inside_its_edges_only() {
        let mut px = blank(30, 30);
        let mut scratch = Scratch::default();
        let mut r = Raster::new(30, 30, &mut px, &mut scratch);
        let v = |x, y| ScreenPoint { x, y, z: 1.0 };
        let square = [v(10.0, 10.0), v(20.0, 10.0), v(20.0, 20.0), v(10.0, 20.0)];
        r.polygon(&square, &[false; 4], [0.0, 100.0, 0.0], &paint([0.0; 3]));
        assert_eq!(at(&px, 30, 15, 15), [0, 100, 0]);
        assert_eq!(at(&px, 30, 10, 15), [0, 100, 0]); // pixel centre 10.5 inside
        assert_eq!(at(&px, 30, 9, 15), [255, 255, 255]);
        assert_eq!(at(&px, 30, 20, 15), [255, 255, 255]);
        // Degenerate and non-finite polygons draw nothing.
        let before = px.clone();
        let mut scratch = Scratch::default();
        let mut r = Raster::new(30, 30, &mut px, &mut scratch);
        r.polygon(
            &[v(1.0, 1.0), v(2.0, 2.0), v(3.0, 3.0)],
            &[],
            [0.0; 3],
            &paint([0.0; 3]),
        );
        r.polygon(
            &[v(f64::NAN, 1.0), v(2.0, 2.0), v(3.0, 9.0)],
            &[],
            [0.0; 3],
            &paint([0.0; 3]),
        );
        assert_eq!(px, before);
    }

    #[test]
    fn depth_buffers_are_cleared_between_frames() {
        let mut scratch = Scratch::default();
        let mut first = blank(20, 20);
        let mut r = Raster::new(20, 20, &mut first, &mut scratch);
        r.sphere(
            ScreenPoint {
                x: 10.0,
                y: 10.0,
                z: 0.5,
            },
            6.0,
            0.1,
            &paint([0.0; 3]),
        );
        // A new frame: the far sphere is no longer hidden by the last frame's near one.
        let mut second = blank(20, 20);
        let mut r = Raster::new(20, 20, &mut second, &mut scratch);
        r.sphere(
            ScreenPoint {
                x: 10.0,
                y: 10.0,
                z: 5.0,
            },
            6.0,
            0.1,
            &paint([0.0, 0.0, 200.0]),
        );
        assert!(at(&second, 20, 10, 10)[2] > 100);
    }

    #[test]
    fn intervals() {
        assert_eq!(linear_interval(2.0, 1.0, 3.0, 5.0), Some((1.0, 2.0)));
        assert_eq!(linear_interval(-1.0, 0.0, 0.0, 1.0), Some((-1.0, 0.0)));
        assert_eq!(linear_interval(0.0, 7.0, 0.0, 1.0), None);
        assert_eq!(pixel_span(0.2, 3.7, 10), 0..4);
        assert_eq!(pixel_span(-5.0, -1.0, 10), 0..0);
        assert_eq!(pixel_span(f64::NAN, f64::NAN, 10), 0..0);
        assert_eq!(round_fast(2.5), 2.0);
        assert_eq!(round_fast(-3.7), -4.0);
    }
}
