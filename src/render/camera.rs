//! The perspective camera of the 3-D view: its settings (checked once) and, for one
//! frame, the pinhole projection of points to pixels.
//!
//! Points are given in a z-up frame `(e1, e2, -e3)` (heights, not the model's
//! gravity-down `e3`), relative to the frame's anchor (the cart when the camera
//! follows it, else the track's centre), so that a cart far out keeps full precision.

use crate::error::{InputError, Result};

/// Settings of the 3-D view's camera. Angles are in degrees.
///
/// At azimuth 0 the camera stands on the `+e2` side and looks along `-e2`, so `e1`
/// points to the right as in the side view; at azimuth 90 it stands on the `+e1`
/// side. Elevation is the angle above the horizontal plane (90: looking straight
/// down).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Direction the camera looks from, degrees (any finite value).
    pub azimuth: f64,
    /// Height of the viewpoint as an angle above the horizontal, degrees in [-90, 90].
    pub elevation: f64,
    /// Distance from the point looked at, m; `None`: the nearest distance that keeps
    /// the chain's reach (and a fixed camera's whole track) in the frame.
    pub distance: Option<f64>,
    /// Vertical field of view, degrees in [1, 120].
    pub fov: f64,
    /// Follow the cart (`Some(true)`), stay fixed on the track's centre
    /// (`Some(false)`), or follow only when the track is more than twice the chain's
    /// length (`None`, as the side view scrolls).
    pub follow: Option<bool>,
}

impl Default for Camera {
    fn default() -> Self {
        Self {
            azimuth: 30.0,
            elevation: 16.0,
            distance: None,
            fov: 35.0,
            follow: None,
        }
    }
}

/// What the camera's `azimuth` accepts.
pub const AZIMUTH_EXPECTED: &str = "a finite angle in degrees";
/// What the camera's `elevation` accepts.
pub const ELEVATION_EXPECTED: &str = "an angle in degrees in [-90, 90]";
/// What the camera's `distance` accepts.
pub const DISTANCE_EXPECTED: &str =
    "a finite distance > 0 in metres, or none for automatic framing";
/// What the camera's `fov` accepts.
pub const FOV_EXPECTED: &str = "a vertical field of view in degrees in [1, 120]";

impl Camera {
    /// Checks every setting, naming the first bad one and what it accepts.
    pub fn validate(&self) -> Result<()> {
        let bad = |name, value, expected| {
            Err(InputError::InvalidParameter {
                name,
                value,
                expected,
            }
            .into())
        };
        if !self.azimuth.is_finite() {
            return bad("azimuth", self.azimuth, AZIMUTH_EXPECTED);
        }
        if !(-90.0..=90.0).contains(&self.elevation) {
            return bad("elevation", self.elevation, ELEVATION_EXPECTED);
        }
        if let Some(d) = self.distance {
            if !(d.is_finite() && d > 0.0) {
                return bad("distance", d, DISTANCE_EXPECTED);
            }
        }
        if !(1.0..=120.0).contains(&self.fov) {
            return bad("fov", self.fov, FOV_EXPECTED);
        }
        Ok(())
    }

    /// The camera's unit vectors `(right, up, forward)` in the z-up frame.
    pub fn basis(&self) -> [[f64; 3]; 3] {
        let (sa, ca) = self.azimuth.to_radians().sin_cos();
        let (se, ce) = self.elevation.to_radians().sin_cos();
        let right = [ca, -sa, 0.0];
        let up = [-se * sa, -se * ca, ce];
        let forward = [-ce * sa, -ce * ca, -se];
        [right, up, forward]
    }
}

/// A point on screen: pixel column `x`, row `y` (both continuous, pixel centres at
/// `+0.5`) and depth `z` along the camera's forward axis, m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScreenPoint {
    /// Column, pixels from the left edge.
    pub x: f64,
    /// Row, pixels from the top edge.
    pub y: f64,
    /// Depth in front of the camera, m.
    pub z: f64,
}

/// The pinhole projection of one frame.
#[derive(Debug, Clone, Copy)]
pub struct Projection {
    /// Camera position (z-up frame, relative to the anchor).
    pub eye: [f64; 3],
    /// Unit vector to the right of the screen.
    pub right: [f64; 3],
    /// Unit vector up the screen.
    pub up: [f64; 3],
    /// Unit vector the camera looks along.
    pub forward: [f64; 3],
    /// Focal length, pixels.
    pub focal: f64,
    /// The principal point (frame centre), pixels.
    pub center: [f64; 2],
    /// Points nearer than this depth are not drawn, m.
    pub near: f64,
}

pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(crate) fn add_scaled(a: [f64; 3], s: f64, b: [f64; 3]) -> [f64; 3] {
    [a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]]
}

/// Focal length in pixels of a vertical field of view `fov` (degrees) on a frame
/// `height` pixels high.
pub fn focal_length(fov: f64, height: usize) -> f64 {
    0.5 * height as f64 / (0.5 * fov.to_radians()).tan()
}

/// Fraction of each half-frame left free around the framed box.
const FRAME_MARGIN: f64 = 0.06;

/// The distance at which a camera looking at the origin with `basis` shows every
/// one of `points` inside the frame (less [`FRAME_MARGIN`]): each point `c` needs a
/// depth `c.f + d` of at least `focal |c.r| / half-width` (and the same for height).
pub fn framing_distance(
    basis: [[f64; 3]; 3],
    points: &[[f64; 3]],
    focal: f64,
    width: usize,
    height: usize,
) -> f64 {
    let [right, up, forward] = basis;
    let half = [
        0.5 * width as f64 * (1.0 - FRAME_MARGIN),
        0.5 * height as f64 * (1.0 - FRAME_MARGIN),
    ];
    points
        .iter()
        .map(|&c| {
            (focal * dot(c, right).abs() / half[0]).max(focal * dot(c, up).abs() / half[1])
                - dot(c, forward)
        })
        .fold(0.0, f64::max)
}

impl Projection {
    /// The camera `camera` looking at `target` from `distance` metres, on a frame of
    /// `width x height` pixels.
    pub fn new(
        camera: &Camera,
        target: [f64; 3],
        distance: f64,
        width: usize,
        height: usize,
    ) -> Self {
        let [right, up, forward] = camera.basis();
        Self {
            eye: add_scaled(target, -distance, forward),
            right,
            up,
            forward,
            focal: focal_length(camera.fov, height),
            center: [0.5 * width as f64, 0.5 * height as f64],
            near: 1e-3 * distance,
        }
    }

    /// Camera coordinates `(right, up, depth)` of a point.
    pub fn to_camera(self, p: [f64; 3]) -> [f64; 3] {
        let d = sub(p, self.eye);
        [dot(d, self.right), dot(d, self.up), dot(d, self.forward)]
    }

    /// The pixel and depth of a point, or `None` when it is not in front of the near
    /// plane (or not finite).
    pub fn project(&self, p: [f64; 3]) -> Option<ScreenPoint> {
        let [x, y, z] = self.to_camera(p);
        if !(z >= self.near && x.is_finite() && y.is_finite() && z.is_finite()) {
            return None;
        }
        Some(ScreenPoint {
            x: self.center[0] + self.focal * x / z,
            y: self.center[1] - self.focal * y / z,
            z,
        })
    }

    /// Pixels per metre at depth `z`.
    pub fn scale_at(&self, z: f64) -> f64 {
        self.focal / z
    }

    /// The segment `a`-`b` cut to the part in front of the near plane (`None`: none).
    pub fn clip_segment(&self, a: [f64; 3], b: [f64; 3]) -> Option<([f64; 3], [f64; 3])> {
        let (za, zb) = (
            dot(sub(a, self.eye), self.forward),
            dot(sub(b, self.eye), self.forward),
        );
        if !(za.is_finite() && zb.is_finite()) || (za < self.near && zb < self.near) {
            return None;
        }
        let cut = |from: [f64; 3], to: [f64; 3], zf: f64, zt: f64| {
            let s = (self.near - zf) / (zt - zf);
            add_scaled(from, s, sub(to, from))
        };
        Some(match (za < self.near, zb < self.near) {
            (true, _) => (cut(a, b, za, zb), b),
            (_, true) => (a, cut(b, a, zb, za)),
            _ => (a, b),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assert_close(a: f64, b: f64, tol: f64) {
        assert!((a - b).abs() <= tol, "{a} vs {b}");
    }

    #[test]
    fn the_basis_is_orthonormal_and_e1_points_right_at_azimuth_zero() {
        for (az, el) in [(0.0, 0.0), (30.0, 16.0), (-135.0, 90.0), (400.0, -90.0)] {
            let cam = Camera {
                azimuth: az,
                elevation: el,
                ..Camera::default()
            };
            let b = cam.basis();
            for i in 0..3 {
                for j in 0..3 {
                    assert_close(dot(b[i], b[j]), if i == j { 1.0 } else { 0.0 }, 1e-12);
                }
            }
        }
        let [right, up, forward] = Camera {
            azimuth: 0.0,
            elevation: 0.0,
            ..Camera::default()
        }
        .basis();
        assert_eq!(right, [1.0, -0.0, 0.0]);
        assert_eq!(up, [-0.0, -0.0, 1.0]);
        assert_eq!(forward, [-0.0, -1.0, -0.0]);
    }

    #[test]
    fn a_known_point_lands_where_the_pinhole_model_says() {
        // Camera at azimuth 90 (on the +e1 side), elevation 0, 2 m from the origin:
        // it sits at (2, 0, 0) looking along -e1; screen right is -e2, up is +z.
        // A 90-degree field of view on a 200 x 100 frame: focal length 50 px.
        let cam = Camera {
            azimuth: 90.0,
            elevation: 0.0,
            fov: 90.0,
            ..Camera::default()
        };
        let p = Projection::new(&cam, [0.0; 3], 2.0, 200, 100);
        assert_close(p.focal, 50.0, 1e-9);
        // The point (0, -0.5, 0.25): 2 m deep, 0.5 m right, 0.25 m up:
        // x = 100 + 50 * 0.5 / 2 = 112.5, y = 50 - 50 * 0.25 / 2 = 43.75.
        let s = p.project([0.0, -0.5, 0.25]).unwrap();
        assert_close(s.x, 112.5, 1e-9);
        assert_close(s.y, 43.75, 1e-9);
        assert_close(s.z, 2.0, 1e-12);
        // Behind the camera: not drawn.
        assert!(p.project([3.0, 0.0, 0.0]).is_none());
        assert!(p.project([f64::NAN, 0.0, 0.0]).is_none());
    }

    #[test]
    fn an_elevated_camera_looks_down_at_its_target() {
        // Elevation 45, azimuth 0, 1 m away, fov 60 on 100 x 100: the target lands at
        // the centre; a point 0.1 m above it lands higher on screen, at the focal
        // length times its offset over its depth.
        let cam = Camera {
            azimuth: 0.0,
            elevation: 45.0,
            fov: 60.0,
            ..Camera::default()
        };
        let p = Projection::new(&cam, [0.3, -0.2, 0.1], 1.0, 100, 100);
        let c = p.project([0.3, -0.2, 0.1]).unwrap();
        assert_close(c.x, 50.0, 1e-9);
        assert_close(c.y, 50.0, 1e-9);
        let f = 50.0 / (30f64.to_radians()).tan();
        let h = std::f64::consts::FRAC_1_SQRT_2 * 0.1; // the 0.1 m rise seen at 45 degrees
        let a = p.project([0.3, -0.2, 0.2]).unwrap();
        assert_close(a.z, 1.0 - h, 1e-12);
        assert_close(a.y, 50.0 - f * h / (1.0 - h), 1e-9);
        assert_close(a.x, 50.0, 1e-9);
    }

    #[test]
    fn the_framing_distance_puts_the_widest_corner_on_the_margin() {
        let cam = Camera {
            azimuth: 0.0,
            elevation: 0.0,
            fov: 90.0,
            ..Camera::default()
        };
        let (lo, hi) = ([-1.0, -0.1, -0.2], [1.0, 0.1, 0.2]);
        let focal = focal_length(cam.fov, 100);
        let corners: Vec<[f64; 3]> = (0..8)
            .map(|i| {
                [
                    if i & 1 == 0 { lo[0] } else { hi[0] },
                    if i & 2 == 0 { lo[1] } else { hi[1] },
                    if i & 4 == 0 { lo[2] } else { hi[2] },
                ]
            })
            .collect();
        let d = framing_distance(cam.basis(), &corners, focal, 100, 100);
        let p = Projection::new(&cam, [0.0; 3], d, 100, 100);
        let mut widest: f64 = 0.0;
        for x in [lo[0], hi[0]] {
            for y in [lo[1], hi[1]] {
                for z in [lo[2], hi[2]] {
                    let s = p.project([x, y, z]).unwrap();
                    assert!(s.y > 0.0 && s.y < 100.0);
                    widest = widest.max((s.x - 50.0).abs());
                }
            }
        }
        assert_close(widest, 50.0 * (1.0 - FRAME_MARGIN), 1e-9);
    }

    #[test]
    fn bad_settings_are_named_with_what_they_accept() {
        let cases = [
            (
                Camera {
                    azimuth: f64::NAN,
                    ..Camera::default()
                },
                "azimuth",
                AZIMUTH_EXPECTED,
            ),
            (
                Camera {
                    elevation: 91.0,
                    ..Camera::default()
                },
                "elevation",
                ELEVATION_EXPECTED,
            ),
            (
                Camera {
                    distance: Some(0.0),
                    ..Camera::default()
                },
                "distance",
                DISTANCE_EXPECTED,
            ),
            (
                Camera {
                    distance: Some(f64::INFINITY),
                    ..Camera::default()
                },
                "distance",
                DISTANCE_EXPECTED,
            ),
            (
                Camera {
                    fov: 0.5,
                    ..Camera::default()
                },
                "fov",
                FOV_EXPECTED,
            ),
            (
                Camera {
                    fov: f64::NAN,
                    ..Camera::default()
                },
                "fov",
                FOV_EXPECTED,
            ),
        ];
        for (cam, name, expected) in cases {
            let e = cam.validate().unwrap_err().to_string();
            assert!(e.contains(name) && e.contains(expected), "{e}");
        }
        assert!(Camera::default().validate().is_ok());
        let extremes = Camera {
            elevation: -90.0,
            fov: 120.0,
            distance: Some(1e-6),
            ..Camera::default()
        };
        assert!(extremes.validate().is_ok());
    }

    #[test]
    fn segments_are_cut_at_the_near_plane() {
        let cam = Camera {
            azimuth: 0.0,
            elevation: 0.0,
            ..Camera::default()
        };
        let p = Projection::new(&cam, [0.0; 3], 1.0, 64, 64);
        // The eye is at (0, 1, 0) looking along -e2; a segment from behind it to the
        // origin is cut where its depth is the near distance.
        let (a, b) = p.clip_segment([0.0, 2.0, 0.0], [0.0, 0.0, 0.0]).unwrap();
        assert_close(p.to_camera(a)[2], p.near, 1e-12);
        assert_eq!(b, [0.0; 3]);
        assert!(p.clip_segment([0.0, 2.0, 0.0], [0.0, 3.0, 0.0]).is_none());
    }
}
