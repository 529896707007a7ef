//! Software rendering of chain states into RGB frames (no windowing, no GPU, no
//! Python): a lit perspective 3-D view (`scene3d`, drawn by `raster` through the
//! `camera`) and the flat side and top views (`scene`, drawn on a [`Canvas`]).

mod camera;
mod canvas;
mod raster;
mod scene;
mod scene3d;

pub use camera::Camera;
pub use canvas::Canvas;
pub use scene::{draw_frame, FrameSpec, ViewKind};

use crate::error::{check_finite, check_len, InputError, Result};

/// Renders one `height x width x 3` frame into `pixels`, validating sizes and the
/// camera. Wild (huge or off-screen) states draw without error; NaN coordinates are
/// skipped.
pub fn render(width: usize, height: usize, spec: &FrameSpec, pixels: &mut [u8]) -> Result<()> {
    check_frame_size(width, height)?;
    spec.camera.validate()?;
    check_len("state", spec.state, 4 + 6 * spec.lengths.len())?;
    check_finite("force", &spec.force)?;
    if let Some(s) = spec.target {
        check_len("target", s, spec.lengths.len())?;
    }
    if pixels.len() != width * height * 3 {
        return Err(InputError::LengthMismatch {
            name: "pixels",
            got: pixels.len(),
            expected: width * height * 3,
        }
        .into());
    }
    if spec.view == ViewKind::ThreeD {
        scene3d::draw_3d(width, height, spec, &spec.camera, pixels);
    } else {
        draw_frame(&mut Canvas::new(width, height, pixels), spec);
    }
    Ok(())
}

/// Smallest frame side the renderer draws, pixels.
pub const MIN_FRAME_SIZE: usize = 16;
/// Largest frame side the renderer draws, pixels.
pub const MAX_FRAME_SIZE: usize = 8192;

/// Frame sizes the renderer accepts: [`MIN_FRAME_SIZE`] to [`MAX_FRAME_SIZE`] pixels
/// each way.
pub fn check_frame_size(width: usize, height: usize) -> Result<()> {
    for (name, value) in [("width", width), ("height", height)] {
        if !(MIN_FRAME_SIZE..=MAX_FRAME_SIZE).contains(&value) {
            return Err(InputError::InvalidParameter {
                name,
                value: value as f64,
                expected: "a frame size between 16 and 8192 pixels",
            }
            .into());
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{ChainParams, SpatialChain};

    fn frame(state: &[f64], target: Option<&[f64]>) -> Vec<u8> {
        let mut px = vec![0u8; 120 * 80 * 3];
        let spec = FrameSpec {
            lengths: &[0.1; 5],
            state,
            target,
            force: [3.0, -1.0],
            max_force: 10.0,
            track_limit: 0.5,
            planar: false,
            view: ViewKind::SideTop,
            camera: Camera::default(),
            trail: &[],
        };
        render(120, 80, &spec, &mut px).unwrap();
        px
    }

    #[test]
    fn frames_depend_on_the_state_only() {
        let chain = SpatialChain::new(ChainParams::paper());
        let hanging = chain.equilibrium(&[1.0; 5]).unwrap();
        let folded = chain.equilibrium(&[1.0, -1.0, 1.0, -1.0, 1.0]).unwrap();
        assert_eq!(frame(&hanging, None), frame(&hanging, None));
        assert_ne!(frame(&hanging, None), frame(&folded, None));
        assert_ne!(frame(&hanging, None), frame(&hanging, Some(&[-1.0; 5])));
    }

    #[test]
    fn the_side_view_stays_in_its_panel() {
        // The track runs across the whole side view; the top view beside it shows a
        // hanging chain as a dot in its middle, so its right edge is background.
        let chain = SpatialChain::new(ChainParams::paper());
        let hanging = chain.equilibrium(&[1.0; 5]).unwrap();
        let spec = FrameSpec {
            lengths: &[0.1; 5],
            state: &hanging,
            target: None,
            force: [0.0; 2],
            max_force: 10.0,
            track_limit: f64::INFINITY,
            planar: false,
            view: ViewKind::SideTop,
            camera: Camera::default(),
            trail: &[],
        };
        let mut px = vec![0u8; 120 * 80 * 3];
        render(120, 80, &spec, &mut px).unwrap();
        let at = |x: usize, y: usize| &px[3 * (y * 120 + x)..3 * (y * 120 + x) + 3];
        assert_ne!(at(2, 40), &[250, 250, 250], "track drawn in the side view");
        assert_eq!(
            at(119, 40),
            &[250, 250, 250],
            "track spilled into the top view"
        );
    }

    #[test]
    fn a_scrolling_track_shows_the_carts_motion() {
        let chain = SpatialChain::new(ChainParams::paper());
        let mut y = chain.equilibrium(&[1.0; 5]).unwrap();
        let draw = |y: &[f64]| {
            let spec = FrameSpec {
                lengths: &[0.1; 5],
                state: y,
                target: None,
                force: [0.0; 2],
                max_force: 10.0,
                track_limit: 10.0,
                planar: false,
                view: ViewKind::Side,
                camera: Camera::default(),
                trail: &[],
            };
            let mut px = vec![0u8; 120 * 80 * 3];
            render(120, 80, &spec, &mut px).unwrap();
            px
        };
        let before = draw(&y);
        y[0] += 0.07;
        assert_ne!(before, draw(&y));
        for x in [1e12, -1e300, 9.99] {
            y[0] = x;
            draw(&y);
        }
    }

    #[test]
    fn wild_states_draw_without_panicking() {
        let chain = SpatialChain::new(ChainParams::paper());
        let mut y = chain.equilibrium(&[1.0; 5]).unwrap();
        y[0] = 1e12;
        y[5] = f64::NAN;
        y[8] = -1e300;
        let px = frame(&y, Some(&[1.0; 5]));
        assert_eq!(px.len(), 120 * 80 * 3);
    }

    #[test]
    fn rejects_bad_sizes() {
        let spec = FrameSpec {
            lengths: &[0.1],
            state: &[0.0; 10],
            target: None,
            force: [0.0; 2],
            max_force: 1.0,
            track_limit: 1.0,
            planar: false,
            view: ViewKind::Side,
            camera: Camera::default(),
            trail: &[],
        };
        assert!(render(4, 4, &spec, &mut [0u8; 48]).is_err());
        assert!(render(32, 32, &spec, &mut [0u8; 10]).is_err());
        let bad = FrameSpec {
            state: &[0.0; 9],
            ..spec
        };
        assert!(render(32, 32, &bad, &mut vec![0u8; 32 * 32 * 3]).is_err());
    }
}

#[cfg(test)]
mod frame_size_tests {
    use super::*;

    #[test]
    fn the_error_states_the_bounds_it_checks() {
        assert!(check_frame_size(MIN_FRAME_SIZE, MAX_FRAME_SIZE).is_ok());
        let e = check_frame_size(MIN_FRAME_SIZE - 1, 100)
            .unwrap_err()
            .to_string();
        let bounds = format!("between {MIN_FRAME_SIZE} and {MAX_FRAME_SIZE} pixels");
        assert!(e.contains(&bounds), "{e}");
        assert!(check_frame_size(100, MAX_FRAME_SIZE + 1).is_err());
    }
}
