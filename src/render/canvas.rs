//! A minimal anti-aliased RGB canvas: capsules (thick segments, discs) and boxes.
//!
//! Every primitive is clipped to the canvas and skipped when its coordinates are
//! not finite, so any state, however wild, draws without panicking.

/// An RGB colour.
pub type Rgb = [u8; 3];

/// Row-major `height x width x 3` bytes.
pub struct Canvas<'a> {
    width: usize,
    height: usize,
    pixels: &'a mut [u8],
    /// Columns `[clip.0, clip.1)` that drawing may touch (a panel of the frame).
    clip: (usize, usize),
}

impl<'a> Canvas<'a> {
    /// Wraps a buffer of exactly `width * height * 3` bytes.
    pub fn new(width: usize, height: usize, pixels: &'a mut [u8]) -> Self {
        assert_eq!(pixels.len(), width * height * 3, "canvas buffer size");
        Self {
            width,
            height,
            pixels,
            clip: (0, width),
        }
    }

    /// Restricts later drawing to the columns `[from, to)` (clamped to the canvas), so
    /// that one panel's shapes never spill into its neighbour.
    pub fn clip_columns(&mut self, from: usize, to: usize) {
        let to = to.min(self.width);
        self.clip = (from.min(to), to);
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }
    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Paints every pixel (inside the clip) with `color`.
    pub fn fill(&mut self, color: Rgb) {
        for px in self.pixels.chunks_exact_mut(3) {
            px.copy_from_slice(&color);
        }
    }

    #[inline]
    fn blend(&mut self, x: usize, y: usize, color: Rgb, alpha: f64) {
        let i = 3 * (y * self.width + x);
        for (c, &target) in self.pixels[i..i + 3].iter_mut().zip(&color) {
            let v = *c as f64 + alpha * (target as f64 - *c as f64);
            *c = v.round().clamp(0.0, 255.0) as u8;
        }
    }

    /// Pixel range covering `[lo, hi]`, clipped to `[min, max)`; empty when outside
    /// or non-finite.
    fn span(lo: f64, hi: f64, (min, max): (usize, usize)) -> std::ops::Range<usize> {
        if !(lo.is_finite() && hi.is_finite()) || hi < min as f64 || lo >= max as f64 {
            return 0..0;
        }
        (lo.max(min as f64).floor() as usize)..((hi.ceil() as usize).min(max))
    }

    /// A segment of the given radius with round ends (radius alone: a disc), blended
    /// with opacity `alpha`; edge pixels get partial coverage.
    pub fn capsule(&mut self, a: [f64; 2], b: [f64; 2], radius: f64, color: Rgb, alpha: f64) {
        if !(a.iter().chain(&b).all(|v| v.is_finite()) && radius.is_finite()) {
            return;
        }
        let reach = radius + 1.0;
        let xs = Self::span(a[0].min(b[0]) - reach, a[0].max(b[0]) + reach, self.clip);
        let ys = Self::span(
            a[1].min(b[1]) - reach,
            a[1].max(b[1]) + reach,
            (0, self.height),
        );
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let len2 = dx * dx + dy * dy;
        for py in ys {
            for px in xs.clone() {
                let (cx, cy) = (px as f64 + 0.5 - a[0], py as f64 + 0.5 - a[1]);
                let t = if len2 > 0.0 {
                    ((cx * dx + cy * dy) / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let (ex, ey) = (cx - t * dx, cy - t * dy);
                let coverage = (radius + 0.5 - (ex * ex + ey * ey).sqrt()).clamp(0.0, 1.0);
                if coverage > 0.0 {
                    self.blend(px, py, color, alpha * coverage);
                }
            }
        }
    }

    /// An axis-aligned filled box from corner `a` to corner `b`.
    pub fn rect(&mut self, a: [f64; 2], b: [f64; 2], color: Rgb, alpha: f64) {
        let xs = Self::span(a[0].min(b[0]), a[0].max(b[0]), self.clip);
        let ys = Self::span(a[1].min(b[1]), a[1].max(b[1]), (0, self.height));
        for py in ys {
            for px in xs.clone() {
                self.blend(px, py, color, alpha);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_and_clips() {
        let mut buf = vec![0u8; 20 * 10 * 3];
        let mut c = Canvas::new(20, 10, &mut buf);
        c.fill([255, 255, 255]);
        c.capsule([2.0, 5.0], [18.0, 5.0], 1.5, [0, 0, 0], 1.0);
        c.capsule([-1e300, 0.0], [1e300, f64::NAN], 3.0, [0, 0, 0], 1.0);
        c.capsule([-50.0, -50.0], [-40.0, -40.0], 3.0, [0, 0, 0], 1.0);
        c.rect([15.0, 0.0], [1e9, 2.0], [255, 0, 0], 1.0);
        let px = |x: usize, y: usize| &buf[3 * (y * 20 + x)..3 * (y * 20 + x) + 3];
        assert_eq!(px(10, 5), &[0, 0, 0]);
        assert_eq!(px(10, 0), &[255, 255, 255]);
        assert_eq!(px(19, 1), &[255, 0, 0]);
    }

    #[test]
    fn clipped_columns_stay_untouched() {
        let mut buf = vec![0u8; 20 * 10 * 3];
        let mut c = Canvas::new(20, 10, &mut buf);
        c.fill([255, 255, 255]);
        c.clip_columns(0, 12);
        c.capsule([-5.0, 5.0], [50.0, 5.0], 2.0, [0, 0, 0], 1.0);
        c.rect([0.0, 0.0], [20.0, 1.0], [255, 0, 0], 1.0);
        let px = |x: usize, y: usize| &buf[3 * (y * 20 + x)..3 * (y * 20 + x) + 3];
        assert_eq!(px(11, 5), &[0, 0, 0]);
        assert_eq!(px(12, 5), &[255, 255, 255]);
        assert_eq!(px(11, 0), &[255, 0, 0]);
        assert_eq!(px(19, 0), &[255, 255, 255]);
    }
}
