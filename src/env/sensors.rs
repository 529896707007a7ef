//! Encoders: what a real rig's sensors report instead of the exact state. Off by
//! default; off, an env observes exactly what it observed without them and costs
//! nothing more.
//!
//! **Positions.** An angle encoder of `N` counts per revolution reports each link's
//! angle on the grid `2 pi / N`, a cart encoder of `c` counts per metre the cart
//! position on the grid `1 / c`, per axis. The reading is the true value rounded
//! *down* to the grid (`floor(value / step) * step`): an incremental encoder counts
//! the edges the moving scale has passed, so its count changes exactly when the true
//! value crosses a grid line, and a value just below a line reads one count lower.
//! Readings are therefore biased by half a count on average, as on a rig.
//!
//! **Angles.** A planar link's angle is `theta = atan2(q . e1, q . e3)`, zero hanging,
//! `pi` upright, increasing with the spin `w` (`w = dtheta/dt`). A spatial link is read
//! by the two encoders of a universal joint whose outer axis is `e2`: its swing `theta`
//! about `e2` (the planar angle) and its tilt `phi` out of the `e1`-`e3` plane,
//! `q = (cos phi sin theta, -sin phi, cos phi cos theta)`, so
//! `theta = atan2(q1, q3)` and `phi = atan2(-q2, hypot(q1, q3))`. Unlike spherical
//! angles these are regular at the hanging and upright directions (the joint's
//! singular directions are `q = +-e2`, the link lying along the swing axis). The
//! observation stays the unit vector of the quantised angles.
//!
//! **Velocities.** With an encoder on, its channel's velocity is estimated as a rig
//! does, from the counts: the change of the quantised reading over the control
//! period `dt` (angles unwrapped across `+-pi`), optionally passed through a
//! first-order low-pass filter of time constant `tau` (`velocity_filter`),
//! `v_t = v_(t-1) + (1 - exp(-dt / tau)) (raw_t - v_(t-1))`, the exact discretisation
//! of `tau dv/dt = raw - v` for a raw estimate held over the period. A spatial link's
//! angle rates are mapped to its angular velocity at the current reading,
//! `w = theta' (e2 + sin phi q) + phi' (cos theta, 0, -sin theta)` (tangent to `q`,
//! `theta' e2` for a link in the plane); the filter acts on the components of `w`.
//! The first reading of an episode (and the reading after `set_state`) has no previous
//! count: its velocity estimate, and the filter's state, are zero, as a rig's estimator
//! starts.
//!
//! **Joint encoders.** With `angle_encoder_reference = "joint"` (planar chains) each
//! link's encoder sits at its joint and reads the link's angle from the link above,
//! `phi_i = theta_i - theta_(i-1)` (the first link's from the vertical, its encoder on
//! the cart), as on a rig with an encoder at each joint. Each relative angle is
//! rounded down to its grid, and the observed angle of link i is the sum of the counts
//! of joints 1..i: it carries the quantisation of every joint above it,
//! `0 <= theta_i - reading_i < i 2 pi / N`. Its velocity is the change of that sum over
//! the period. A spatial link on a spherical joint has no frame fixed to the link above
//! to measure in (the links are rods that carry no twist), so joint encoders are
//! refused on spatial chains.
//!
//! **Channels.** Each encoder replaces only its own channel: with only a cart encoder
//! the links are observed as without encoders, and the other way round.
//!
//! **Noise.** With `obs_noise` the encoders read the noisy value: the noise is added to
//! the true state first (the same draws, in the same order, as without encoders) and
//! the encoder counts what it sees, so every reading stays on its grid (an encoder's
//! counts carry no noise of their own; noise before the count stands for vibration and
//! electrical jitter at the edges). The noise drawn for an estimated velocity is
//! unused: that velocity comes from the counts.

use crate::error::{InputError, Result};
use crate::geometry::{Geometry, Layout, Vector};
use std::f64::consts::PI;

/// What `angle_encoder_counts` accepts.
pub const ANGLE_COUNTS_EXPECTED: &str =
    "an integer from 1 to 4294967295 (counts per revolution), or none for exact angles";
/// What `cart_encoder_counts` accepts.
pub const CART_COUNTS_EXPECTED: &str =
    "a finite number > 0 (counts per metre), or none for an exact position";
/// What `velocity_filter` accepts.
pub const VELOCITY_FILTER_EXPECTED: &str =
    "a finite number >= 0 (s), and 0 unless an encoder is on";

/// What `angle_encoder_reference` accepts.
pub const ANGLE_REFERENCE_EXPECTED: &str = "one of vertical, joint (joint: planar chains with \
     angle_encoder_counts only)";

/// What each link's angle encoder measures the link from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AngleReference {
    /// The vertical: every link's absolute angle.
    #[default]
    Vertical,
    /// The link above (the first link: the vertical), by an encoder at the joint.
    Joint,
}

impl AngleReference {
    /// The accepted names, in the order of the variants.
    pub const NAMES: [&'static str; 2] = ["vertical", "joint"];

    /// The reference named `name`.
    pub fn from_name(name: &str) -> Result<Self> {
        match name {
            "vertical" => Ok(Self::Vertical),
            "joint" => Ok(Self::Joint),
            _ => Err(InputError::UnknownName {
                kind: "angle_encoder_reference",
                name: name.to_string(),
                expected: &Self::NAMES,
            }
            .into()),
        }
    }
}

/// The encoders of an env (default: none, the exact state).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Sensors {
    /// Counts per revolution of every link angle (`None`: exact angles and velocities).
    pub angle_counts: Option<u32>,
    /// Counts per metre of the cart position, per axis (`None`: exact position and
    /// velocity).
    pub cart_counts: Option<f64>,
    /// Time constant (s) of the first-order filter of the estimated velocities; 0: the
    /// raw finite differences.
    pub velocity_filter: f64,
    /// What the angle encoders measure each link from.
    pub angle_reference: AngleReference,
}

impl Sensors {
    /// Some encoder is on.
    #[inline(always)]
    pub fn is_on(&self) -> bool {
        self.angle_counts.is_some() || self.cart_counts.is_some()
    }

    /// Checks the resolutions and the filter (a filter needs an encoder whose velocity
    /// it filters).
    pub fn validate(&self) -> Result<()> {
        if self.angle_counts == Some(0) {
            return Err(InputError::InvalidParameter {
                name: "angle_encoder_counts",
                value: 0.0,
                expected: ANGLE_COUNTS_EXPECTED,
            }
            .into());
        }
        if let Some(c) = self.cart_counts {
            if !(c.is_finite() && c > 0.0) {
                return Err(InputError::InvalidParameter {
                    name: "cart_encoder_counts",
                    value: c,
                    expected: CART_COUNTS_EXPECTED,
                }
                .into());
            }
        }
        let tau = self.velocity_filter;
        if !(tau.is_finite() && tau >= 0.0) || (tau > 0.0 && !self.is_on()) {
            return Err(InputError::InvalidParameter {
                name: "velocity_filter",
                value: tau,
                expected: VELOCITY_FILTER_EXPECTED,
            }
            .into());
        }
        if self.angle_reference == AngleReference::Joint && self.angle_counts.is_none() {
            return Err(Self::joint_reference_refused(
                "angle_encoder_counts set: joint encoders are angle encoders (or use vertical)",
            ));
        }
        Ok(())
    }

    /// Checks what needs the chain's geometry: joint encoders on a planar chain only.
    pub fn validate_for<G: Geometry>(&self) -> Result<()> {
        if self.angle_reference == AngleReference::Joint && G::Link::DIM != 2 {
            return Err(Self::joint_reference_refused(
                "a planar chain: a spherical joint between rods that carry no twist has no frame \
                 fixed to the link above to measure in (use vertical)",
            ));
        }
        Ok(())
    }

    fn joint_reference_refused(expected: &str) -> crate::ChainError {
        InputError::Incompatible {
            name: "angle_encoder_reference",
            value: "joint",
            expected: expected.to_string(),
        }
        .into()
    }

    /// The filter's weight of a new raw estimate, `1 - exp(-dt / tau)`, or `None`
    /// without a filter.
    #[inline]
    pub fn filter_gain(&self, dt: f64) -> Option<f64> {
        (self.velocity_filter > 0.0).then(|| -(-dt / self.velocity_filter).exp_m1())
    }

    /// One reading: `row` holds the previous reading (ignored when `first`) and
    /// receives the new one; `seen(k)` is the value the sensors see of state component
    /// `k` (the true one, or with noise), called once per component in increasing `k`.
    pub fn read<G: Geometry>(
        &self,
        layout: Layout<G>,
        mut seen: impl FnMut(usize) -> f64,
        first: bool,
        dt: f64,
        row: &mut [f64],
    ) {
        let gain = self.filter_gain(dt);
        let estimate = Estimate { first, dt, gain };
        let cart_dim = G::Cart::DIM;
        let mut x = [0.0; 2];
        for (k, xk) in x.iter_mut().enumerate().take(cart_dim) {
            *xk = seen(layout.x() + k);
        }
        for (k, &xk) in x.iter().enumerate().take(cart_dim) {
            let (ix, iv) = (layout.x() + k, layout.xdot() + k);
            let v = seen(iv);
            match self.cart_counts {
                None => (row[ix], row[iv]) = (xk, v),
                Some(c) => {
                    let count = (xk * c).floor();
                    let moved = if first {
                        0.0
                    } else {
                        count - (row[ix] * c).round()
                    };
                    row[ix] = count / c;
                    row[iv] = estimate.velocity(row[iv], moved / c);
                }
            }
        }
        let mut above = JointsAbove::default();
        for i in 0..layout.n {
            let iq = layout.q(i);
            let mut q = [0.0; 3];
            for (m, qm) in q.iter_mut().enumerate().take(G::Link::DIM) {
                *qm = seen(iq + m);
            }
            match self.angle_counts {
                None => row[iq..iq + G::Link::DIM].copy_from_slice(&q[..G::Link::DIM]),
                Some(counts) => {
                    let iw = layout.w(i);
                    let (q_row, w_row) = row.split_at_mut(iw);
                    let link = LinkEncoder::new(counts);
                    if G::Link::DIM == 2 && self.angle_reference == AngleReference::Joint {
                        let (q_out, w_out) = (&mut q_row[iq..iq + 2], &mut w_row[0]);
                        link.read_planar_joint(&q, q_out, w_out, &estimate, &mut above);
                    } else if G::Link::DIM == 2 {
                        link.read_planar(&q, &mut q_row[iq..iq + 2], &mut w_row[0], &estimate);
                    } else {
                        link.read_spatial(&q, &mut q_row[iq..iq + 3], &mut w_row[..3], &estimate);
                    }
                }
            }
        }
        for i in 0..layout.n {
            for m in 0..G::Spin::DIM {
                let k = layout.w(i) + m;
                let w = seen(k);
                if self.angle_counts.is_none() {
                    row[k] = w;
                }
            }
        }
    }
}

/// How one reading turns a change of count into a velocity estimate.
struct Estimate {
    /// No previous reading: the estimate is zero.
    first: bool,
    dt: f64,
    /// [`Sensors::filter_gain`].
    gain: Option<f64>,
}

impl Estimate {
    /// The new estimate from the previous one (the filter's state) and the change of
    /// the reading over the period.
    #[inline(always)]
    fn velocity(&self, previous: f64, change: f64) -> f64 {
        if self.first {
            return 0.0;
        }
        let raw = change / self.dt;
        match self.gain {
            None => raw,
            Some(a) => previous + a * (raw - previous),
        }
    }
}

/// The encoder of one link angle: `counts` per revolution.
struct LinkEncoder {
    counts: f64,
    step: f64,
}

impl LinkEncoder {
    fn new(counts: u32) -> Self {
        let counts = counts as f64;
        Self {
            counts,
            step: 2.0 * PI / counts,
        }
    }

    /// The count of a true angle (rounded down to the grid).
    #[inline(always)]
    fn count(&self, angle: f64) -> f64 {
        (angle / self.step).floor()
    }

    /// The count of an angle already on the grid (recovered from a stored reading).
    #[inline(always)]
    fn recount(&self, angle: f64) -> f64 {
        (angle / self.step).round()
    }

    /// Counts moved from `before` to `after` along the shorter way round (an angle
    /// wraps, its encoder's count does not jump).
    #[inline(always)]
    fn unwrapped(&self, after: f64, before: f64) -> f64 {
        let d = after - before;
        d - self.counts * (d / self.counts).round()
    }

    fn read_planar(&self, seen: &[f64; 3], q_out: &mut [f64], w_out: &mut f64, e: &Estimate) {
        let count = self.count(seen[0].atan2(seen[1]));
        let moved = if e.first {
            0.0
        } else {
            self.unwrapped(count, self.recount(q_out[0].atan2(q_out[1])))
        };
        let theta = count * self.step;
        let (s, c) = theta.sin_cos();
        q_out.copy_from_slice(&[s, c]);
        *w_out = e.velocity(*w_out, moved * self.step);
    }

    /// A planar link read by the encoder at its joint (module docs): `above` holds what
    /// the joints above have read and is advanced past this one.
    fn read_planar_joint(
        &self,
        seen: &[f64; 3],
        q_out: &mut [f64],
        w_out: &mut f64,
        e: &Estimate,
        above: &mut JointsAbove,
    ) {
        let theta = seen[0].atan2(seen[1]);
        let count = self.count(wrap_angle(theta - above.seen));
        let previous = q_out[0].atan2(q_out[1]);
        let moved = if e.first {
            0.0
        } else {
            self.unwrapped(count, self.recount(wrap_angle(previous - above.previous)))
        };
        above.seen = theta;
        above.previous = previous;
        above.counts += count;
        above.moved += moved;
        let (s, c) = (above.counts * self.step).sin_cos();
        q_out.copy_from_slice(&[s, c]);
        *w_out = e.velocity(*w_out, above.moved * self.step);
    }

    fn read_spatial(&self, seen: &[f64; 3], q_out: &mut [f64], w_out: &mut [f64], e: &Estimate) {
        let [theta_count, phi_count] = self.angle_counts(seen, Self::count);
        let [theta_moved, phi_moved] = if e.first {
            [0.0, 0.0]
        } else {
            let [theta_before, phi_before] =
                self.angle_counts(&[q_out[0], q_out[1], q_out[2]], Self::recount);
            [
                self.unwrapped(theta_count, theta_before),
                phi_count - phi_before,
            ]
        };
        let (theta, phi) = (theta_count * self.step, phi_count * self.step);
        let q = gimbal_direction(theta, phi);
        q_out.copy_from_slice(&q);
        let w = gimbal_spin(theta, phi, theta_moved * self.step, phi_moved * self.step);
        for (out, change) in w_out.iter_mut().zip(w) {
            *out = e.velocity(*out, change);
        }
    }

    /// The counts of a direction's swing and tilt angles.
    #[inline(always)]
    fn angle_counts(&self, q: &[f64; 3], count: fn(&Self, f64) -> f64) -> [f64; 2] {
        let (theta, phi) = gimbal_angles(q);
        [count(self, theta), count(self, phi)]
    }
}

/// What the joint encoders above a link have read (all zero above the first link: the
/// cart does not turn).
#[derive(Default)]
struct JointsAbove {
    /// The angle of the link above as the sensors see it (true, or noisy).
    seen: f64,
    /// The link above's previous reading.
    previous: f64,
    /// The sum of the joints' counts: the link above's reading in counts.
    counts: f64,
    /// The sum of the joints' changes of count since the previous reading.
    moved: f64,
}

/// `d` wrapped into `[-pi, pi]`.
#[inline(always)]
fn wrap_angle(d: f64) -> f64 {
    d - 2.0 * PI * (d / (2.0 * PI)).round()
}

/// Swing `theta` about `e2` and tilt `phi` of a (not necessarily unit) direction.
#[inline(always)]
pub fn gimbal_angles(q: &[f64; 3]) -> (f64, f64) {
    (q[0].atan2(q[2]), (-q[1]).atan2(q[0].hypot(q[2])))
}

/// The unit direction of swing `theta` and tilt `phi`.
#[inline(always)]
pub fn gimbal_direction(theta: f64, phi: f64) -> [f64; 3] {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    [cp * st, -sp, cp * ct]
}

/// The angular velocity (tangent to the direction) of angle rates `theta_rate`,
/// `phi_rate` at `(theta, phi)`: `theta' (e2 + sin phi q) + phi' (cos theta, 0,
/// -sin theta)`. Linear in the rates, so it also maps angle changes to `w dt`.
#[inline(always)]
pub fn gimbal_spin(theta: f64, phi: f64, theta_rate: f64, phi_rate: f64) -> [f64; 3] {
    let q = gimbal_direction(theta, phi);
    let sp = phi.sin();
    let (st, ct) = theta.sin_cos();
    [
        theta_rate * sp * q[0] + phi_rate * ct,
        theta_rate * (1.0 + sp * q[1]),
        theta_rate * sp * q[2] - phi_rate * st,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Planar, Spatial};

    fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    }

    #[test]
    fn the_gimbal_spin_moves_the_direction_as_the_angles_do() {
        // w x q against the central difference of q(theta(t), phi(t)).
        let (theta, phi, a, b) = (2.5, -0.4, 1.3, -0.7);
        let h = 1e-6;
        let at = |t: f64| gimbal_direction(theta + a * t, phi + b * t);
        let (plus, minus) = (at(h), at(-h));
        let w = gimbal_spin(theta, phi, a, b);
        let q = gimbal_direction(theta, phi);
        let qdot = cross(w, q);
        for m in 0..3 {
            let numeric = (plus[m] - minus[m]) / (2.0 * h);
            assert!((qdot[m] - numeric).abs() < 1e-8, "{m}: {qdot:?}");
        }
        let tangency: f64 = (0..3).map(|m| w[m] * q[m]).sum();
        assert!(tangency.abs() < 1e-14);
        let (t, p) = gimbal_angles(&q);
        assert!((t - theta).abs() < 1e-14 && (p - phi).abs() < 1e-14);
    }

    #[test]
    fn readings_are_the_floor_of_the_grid() {
        let sensors = Sensors {
            angle_counts: Some(8),
            cart_counts: Some(10.0),
            velocity_filter: 0.0,
            angle_reference: AngleReference::Vertical,
        };
        let layout = Layout::<Planar>::new(1);
        // x = 0.27 m, theta = 0.5 rad (hanging side), w = 3, xdot = 1.
        let y = [0.27, 1.0, 0.5f64.sin(), 0.5f64.cos(), 3.0];
        let mut row = [0.0; 5];
        sensors.read(layout, |k| y[k], true, 0.02, &mut row);
        let step = PI / 4.0;
        assert_eq!(row[0], 0.2);
        assert_eq!([row[2], row[3]], [0.0, 1.0]);
        assert_eq!((row[1], row[4]), (0.0, 0.0), "first reading: no estimate");
        // Next period: x = 0.31 (3 counts), theta = 0.9 (1 count of pi/4).
        let y = [0.31, 1.0, 0.9f64.sin(), 0.9f64.cos(), 3.0];
        sensors.read(layout, |k| y[k], false, 0.02, &mut row);
        assert_eq!(row[0], 0.3);
        assert!((row[1] - 0.1 / 0.02).abs() < 1e-12);
        assert!((row[2] - step.sin()).abs() < 1e-15);
        assert!((row[4] - step / 0.02).abs() < 1e-12);
        // A negative angle rounds down, away from zero.
        let y = [-0.01, 0.0, (-0.1f64).sin(), (-0.1f64).cos(), 0.0];
        sensors.read(layout, |k| y[k], true, 0.02, &mut row);
        assert_eq!(row[0], -0.1);
        assert!((row[2] - (-step).sin()).abs() < 1e-15);
    }

    #[test]
    fn angle_changes_unwrap_across_the_upright() {
        let sensors = Sensors {
            angle_counts: Some(1000),
            ..Sensors::default()
        };
        let layout = Layout::<Planar>::new(1);
        let state = |theta: f64| [0.0, 0.0, theta.sin(), theta.cos(), 0.0];
        let mut row = [0.0; 5];
        let y = state(PI - 0.001);
        sensors.read(layout, |k| y[k], true, 0.01, &mut row);
        let y = state(-PI + 0.004);
        sensors.read(layout, |k| y[k], false, 0.01, &mut row);
        // From count 499 to count -500, one count past the upright: +1, not -999.
        let step = 2.0 * PI / 1000.0;
        let before = ((PI - 0.001) / step).floor();
        let after = ((-PI + 0.004) / step).floor() + 1000.0;
        assert!(
            (row[4] - (after - before) * step / 0.01).abs() < 1e-9,
            "{row:?}"
        );
        assert!(row[4] > 0.0 && row[4] < 1.0);
    }

    #[test]
    fn the_filter_follows_its_recurrence() {
        let sensors = Sensors {
            cart_counts: Some(1000.0),
            velocity_filter: 0.05,
            ..Sensors::default()
        };
        let layout = Layout::<Planar>::new(1);
        let dt = 0.01;
        let a = 1.0 - (-dt / 0.05f64).exp();
        let mut row = [0.0; 5];
        let mut v = 0.0;
        for t in 0..20 {
            let x = 0.5 * (t as f64 * dt);
            let y = [x, 0.5, 0.0, 1.0, 0.0];
            let previous = row[0];
            sensors.read(layout, |k| y[k], t == 0, dt, &mut row);
            if t > 0 {
                let raw = (row[0] - previous) / dt;
                v += a * (raw - v);
            }
            assert!((row[1] - v).abs() < 1e-9, "{t}: {} vs {v}", row[1]);
        }
        assert!((v - 0.5).abs() < 0.1, "tends to the speed: {v}");
    }

    #[test]
    fn a_spatial_link_in_the_plane_reads_as_a_planar_one() {
        let sensors = Sensors {
            angle_counts: Some(360),
            cart_counts: Some(500.0),
            velocity_filter: 0.0,
            angle_reference: AngleReference::Vertical,
        };
        let (planar, spatial) = (Layout::<Planar>::new(1), Layout::<Spatial>::new(1));
        let mut rows = ([0.0; 5], [0.0; 10]);
        for (t, theta) in [2.0f64, 2.3, -3.1].into_iter().enumerate() {
            let p = [0.123 * t as f64, 0.0, theta.sin(), theta.cos(), 0.0];
            let mut s = [0.0; 10];
            crate::geometry::planar_to_spatial(1, &p, &mut s);
            sensors.read(planar, |k| p[k], t == 0, 0.02, &mut rows.0);
            sensors.read(spatial, |k| s[k], t == 0, 0.02, &mut rows.1);
            let mut back = [0.0; 5];
            crate::geometry::spatial_to_planar(1, &rows.1, &mut back);
            for (k, (b, p)) in back.iter().zip(&rows.0).enumerate() {
                assert!((b - p).abs() < 1e-12, "{t} {k}");
            }
        }
    }

    #[test]
    fn bad_values_are_named() {
        let cases = [
            (
                Sensors {
                    angle_counts: Some(0),
                    ..Sensors::default()
                },
                "angle_encoder_counts",
                ANGLE_COUNTS_EXPECTED,
            ),
            (
                Sensors {
                    cart_counts: Some(-5.0),
                    ..Sensors::default()
                },
                "cart_encoder_counts",
                CART_COUNTS_EXPECTED,
            ),
            (
                Sensors {
                    cart_counts: Some(100.0),
                    velocity_filter: f64::NAN,
                    ..Sensors::default()
                },
                "velocity_filter",
                VELOCITY_FILTER_EXPECTED,
            ),
            (
                Sensors {
                    velocity_filter: 0.1,
                    ..Sensors::default()
                },
                "velocity_filter",
                VELOCITY_FILTER_EXPECTED,
            ),
        ];
        for (sensors, name, expected) in cases {
            let e = sensors.validate().unwrap_err().to_string();
            assert!(e.contains(name) && e.contains(expected), "{e}");
        }
        assert!(Sensors::default().validate().is_ok());
    }
}
