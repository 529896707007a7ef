//! Envs kept component-major in lane groups between steps: stepping them again needs
//! no transposes, which otherwise cost a fifth to a quarter of a lane step. Rows are
//! moved in or out only when the caller reads or writes states.

// Index loops on purpose: they must inline into the dispatched kernels.
#![allow(clippy::needless_range_loop)]

use super::dispatch::{run_on, Kernel, LaneWork};
use super::simd::{LaneReal, Lanes};
use super::transpose::RowMover;

/// The states of `num_envs` envs, `L` per lane group: component j of env `g*L + k` is
/// `lanes[g*dim + j].0[k]`. Lanes past the last env (in the last group) carry a copy
/// of that group's first env when loaded from rows; nobody reads them.
#[derive(Debug, Clone)]
pub struct LaneStates<const L: usize, T: LaneReal = f64> {
    dim: usize,
    num_envs: usize,
    lanes: Vec<Lanes<L, T>>,
}

impl<const L: usize, T: LaneReal> LaneStates<L, T> {
    /// Room for `num_envs` states of `dim` numbers (all zero).
    pub fn new(dim: usize, num_envs: usize) -> Self {
        Self {
            dim,
            num_envs,
            lanes: vec![Lanes::zero(); num_envs.div_ceil(L) * dim],
        }
    }

    /// Number of envs.
    pub fn num_envs(&self) -> usize {
        self.num_envs
    }

    /// Length of one state.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The lane groups, one after the other, `dim` lanes each.
    pub fn lanes(&self) -> &[Lanes<L, T>] {
        &self.lanes
    }

    /// The lane groups, for stepping in place.
    pub fn lanes_mut(&mut self) -> &mut [Lanes<L, T>] {
        &mut self.lanes
    }

    /// Every env from `rows` (env-major, `dim` each), rounded to the lane type.
    pub fn load_rows(&mut self, kernel: Kernel, rows: &[f64]) {
        assert_eq!(rows.len(), self.num_envs * self.dim, "rows of every env");
        load_groups(kernel, &mut self.lanes, rows, self.dim);
    }

    /// Every env into `rows` (env-major, `dim` each), widened to f64 (exactly).
    pub fn store_rows(&self, kernel: Kernel, rows: &mut [f64]) {
        assert_eq!(rows.len(), self.num_envs * self.dim, "rows of every env");
        store_groups(kernel, &self.lanes, rows, self.dim);
    }

    /// Env `env` from `row`, rounded to the lane type.
    pub fn load_row(&mut self, env: usize, row: &[f64]) {
        let (group, lane) = self.place(env);
        for (lanes, &v) in group.iter_mut().zip(row) {
            lanes.0[lane] = T::from_f64(v);
        }
    }

    /// Env `env` into `row`, widened to f64.
    pub fn store_row(&self, env: usize, row: &mut [f64]) {
        let (g, lane) = (env / L, env % L);
        let group = &self.lanes[g * self.dim..(g + 1) * self.dim];
        for (v, lanes) in row.iter_mut().zip(group) {
            *v = lanes.0[lane].to_f64();
        }
    }

    /// Env `env`'s lane group and its lane in it.
    fn place(&mut self, env: usize) -> (&mut [Lanes<L, T>], usize) {
        assert!(env < self.num_envs, "env {env} of {}", self.num_envs);
        let (g, d) = (env / L, self.dim);
        (&mut self.lanes[g * d..(g + 1) * d], env % L)
    }
}

/// Fills the lane groups `lanes` (`dim` lanes each) from the env-major `rows` of as
/// many envs as `rows` holds (at most `L` per group), compiled for `kernel`. Lanes
/// past the last env copy their group's first env.
pub fn load_groups<const L: usize, T: LaneReal>(
    kernel: Kernel,
    lanes: &mut [Lanes<L, T>],
    rows: &[f64],
    dim: usize,
) {
    run_on(kernel, LoadRows { lanes, rows, dim });
}

/// Writes the env-major `rows` of as many envs as `rows` holds from the lane groups
/// `lanes` (`dim` lanes each), compiled for `kernel`.
pub fn store_groups<const L: usize, T: LaneReal>(
    kernel: Kernel,
    lanes: &[Lanes<L, T>],
    rows: &mut [f64],
    dim: usize,
) {
    run_on(kernel, StoreRows { lanes, rows, dim });
}

struct LoadRows<'a, const L: usize, T: LaneReal> {
    lanes: &'a mut [Lanes<L, T>],
    rows: &'a [f64],
    dim: usize,
}

impl<const L: usize, T: LaneReal> LaneWork for LoadRows<'_, L, T> {
    #[inline(always)]
    fn run<R: RowMover>(self) {
        let (d, n) = (self.dim, self.rows.len() / self.dim);
        for (g, y) in self
            .lanes
            .chunks_exact_mut(d)
            .enumerate()
            .take(n.div_ceil(L))
        {
            let first = g * L;
            R::rows_to_lanes(self.rows, d, first, L.min(n - first), y);
        }
    }
}

struct StoreRows<'a, const L: usize, T: LaneReal> {
    lanes: &'a [Lanes<L, T>],
    rows: &'a mut [f64],
    dim: usize,
}

impl<const L: usize, T: LaneReal> LaneWork for StoreRows<'_, L, T> {
    #[inline(always)]
    fn run<R: RowMover>(self) {
        let (d, n) = (self.dim, self.rows.len() / self.dim);
        for (g, y) in self.lanes.chunks_exact(d).enumerate().take(n.div_ceil(L)) {
            let first = g * L;
            let write: [bool; L] = std::array::from_fn(|k| first + k < n);
            R::lanes_to_rows(y, self.rows, d, first, &write);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_go_in_and_come_back_on_every_kernel() {
        let (d, n) = (7, 21);
        let rows: Vec<f64> = (0..n * d).map(|i| i as f64 * 0.37 - 3.0).collect();
        for kernel in Kernel::ALL.into_iter().filter(|k| k.is_available()) {
            let mut states = LaneStates::<8, f64>::new(d, n);
            states.load_rows(kernel, &rows);
            let mut back = vec![0.0; n * d];
            states.store_rows(kernel, &mut back);
            assert_eq!(back, rows, "{kernel:?}");
            // The padding lanes of the last group copy its first env.
            let last = &states.lanes()[2 * d..];
            assert_eq!(last[3].0[7], rows[16 * d + 3], "{kernel:?}");
            let mut row = vec![0.0; d];
            states.store_row(13, &mut row);
            assert_eq!(row, rows[13 * d..14 * d], "{kernel:?}");
            let new: Vec<f64> = (0..d).map(|j| -(j as f64)).collect();
            states.load_row(13, &new);
            states.store_rows(kernel, &mut back);
            assert_eq!(back[13 * d..14 * d], new[..], "{kernel:?}");
            assert_eq!(back[12 * d..13 * d], rows[12 * d..13 * d], "{kernel:?}");
        }
    }

    #[test]
    fn f32_lanes_round_once_and_widen_exactly() {
        let (d, n) = (5, 19);
        let rows: Vec<f64> = (0..n * d).map(|i| (i as f64 + 0.1) / 3.0).collect();
        for kernel in Kernel::ALL.into_iter().filter(|k| k.is_available()) {
            let mut states = LaneStates::<16, f32>::new(d, n);
            states.load_rows(kernel, &rows);
            let mut back = vec![0.0; n * d];
            states.store_rows(kernel, &mut back);
            let rounded: Vec<f64> = rows.iter().map(|&v| v as f32 as f64).collect();
            assert_eq!(back, rounded, "{kernel:?}");
            states.load_rows(kernel, &back);
            let mut again = vec![0.0; n * d];
            states.store_rows(kernel, &mut again);
            assert_eq!(again, rounded, "{kernel:?}");
        }
    }
}
