//! The narrow interface through which a layer above reads states in the lanes: work
//! done on each lane group right after its step, before it is written back (the task
//! measures its reward and errors this way). The hook is a type parameter, so its
//! code is compiled into each dispatched kernel like the step itself.

use super::simd::{LaneReal, Lanes};
use super::{LANES, LANES_F32};
use crate::geometry::{Geometry, Layout};

/// Work on each stepped lane group of `L` lanes of `T`.
pub trait AfterStep<G: Geometry, const L: usize, T: LaneReal> {
    /// Group `y` holds envs `first..first + filled` (lanes that failed hold garbage).
    fn group(&mut self, lay: Layout<G>, y: &[Lanes<L, T>], first: usize, filled: usize);
}

impl<G: Geometry, const L: usize, T: LaneReal, A: AfterStep<G, L, T> + ?Sized> AfterStep<G, L, T>
    for &mut A
{
    #[inline(always)]
    fn group(&mut self, lay: Layout<G>, y: &[Lanes<L, T>], first: usize, filled: usize) {
        (**self).group(lay, y, first, filled)
    }
}

/// Nothing after the step.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoHook;

impl<G: Geometry, const L: usize, T: LaneReal> AfterStep<G, L, T> for NoHook {
    #[inline(always)]
    fn group(&mut self, _: Layout<G>, _: &[Lanes<L, T>], _: usize, _: usize) {}
}

/// A hook for every lane width and number type a chunk may be stepped in (see
/// [`super::chunk_lanes`]).
pub trait LaneHook<G: Geometry>:
    AfterStep<G, LANES, f64>
    + AfterStep<G, { 2 * LANES }, f64>
    + AfterStep<G, LANES_F32, f32>
    + AfterStep<G, { 2 * LANES_F32 }, f32>
    + Send
    + Sync
    + 'static
{
}
impl<G: Geometry, H> LaneHook<G> for H where
    H: AfterStep<G, LANES, f64>
        + AfterStep<G, { 2 * LANES }, f64>
        + AfterStep<G, LANES_F32, f32>
        + AfterStep<G, { 2 * LANES_F32 }, f32>
        + Send
        + Sync
        + 'static
{
}

/// Room for the per-env values of `num_envs` envs that lane groups of any width (up
/// to two vectors of f32) read or write whole.
pub fn room(num_envs: usize) -> usize {
    num_envs.div_ceil(2 * LANES_F32) * 2 * LANES_F32
}
