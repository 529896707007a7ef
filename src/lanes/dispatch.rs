//! Run-time choice of the compiled kernel. The lane kernel is compiled once per
//! instruction set below (the generic body is inlined into each clone, which carries
//! the target features) and the best one the CPU supports is picked by feature
//! detection, so the shipped library is built for baseline x86-64 and still uses
//! AVX2 or AVX-512 where present. No clone enables FMA: results are the same on all.

#[cfg(target_arch = "x86_64")]
use super::transpose::Avx512Rows;
use super::transpose::{RowMover, ScalarRows};
use crate::error::{InputError, Result};

/// One compiled variant of the lane kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Kernel {
    /// The build's baseline instruction set (SSE2 on x86-64, NEON on aarch64).
    Baseline,
    /// x86-64 with AVX2 (256-bit registers).
    Avx2,
    /// x86-64 with AVX-512F (512-bit registers).
    Avx512,
}

impl Kernel {
    /// Every kernel, slowest first.
    pub const ALL: [Kernel; 3] = [Kernel::Baseline, Kernel::Avx2, Kernel::Avx512];

    /// The kernel's name.
    pub fn name(self) -> &'static str {
        match self {
            Kernel::Baseline => "baseline",
            Kernel::Avx2 => "avx2",
            Kernel::Avx512 => "avx512",
        }
    }

    /// Whether this CPU can run the kernel.
    pub fn is_available(self) -> bool {
        match self {
            Kernel::Baseline => true,
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx2 => std::arch::is_x86_feature_detected!("avx2"),
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx512 => std::arch::is_x86_feature_detected!("avx512f"),
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// The widest kernel this CPU runs.
    pub fn detect() -> Kernel {
        *Kernel::ALL
            .iter()
            .rev()
            .find(|k| k.is_available())
            .unwrap_or(&Kernel::Baseline)
    }

    /// `self`, or an error naming it if this CPU cannot run it.
    pub fn checked(self) -> Result<Kernel> {
        self.available_or(
            "a kernel this CPU supports (see Kernel::is_available)",
            self.is_available(),
        )
    }

    /// `self` if `ok`, else an error naming the kernel and saying what was `expected`.
    pub(crate) fn available_or(self, expected: &'static str, ok: bool) -> Result<Kernel> {
        if ok {
            return Ok(self);
        }
        Err(InputError::InvalidParameter {
            name: "kernel",
            value: self as u8 as f64,
            expected,
        }
        .into())
    }
}

/// Work on lane groups that is compiled once per kernel: [`LaneWork::run`] is
/// `#[inline(always)]` in every implementation, so each dispatched clone below gets
/// its own copy with the clone's instruction set. `R` is how the clone moves env rows
/// into lanes and back.
pub(crate) trait LaneWork {
    /// Does the work, moving rows with `R`.
    fn run<R: RowMover>(self);
}

/// Runs `work` compiled for `kernel`. A kernel the CPU lacks is never run: it falls
/// back to the baseline one (callers check with [`Kernel::checked`]).
#[inline(always)]
pub(crate) fn run_on<W: LaneWork>(kernel: Kernel, work: W) {
    #[cfg(target_arch = "x86_64")]
    {
        if kernel == Kernel::Avx512 && kernel.is_available() {
            // SAFETY: the CPU supports AVX-512F (checked just above).
            return unsafe { on_avx512(work) };
        }
        if kernel == Kernel::Avx2 && kernel.is_available() {
            // SAFETY: the CPU supports AVX2 (checked just above).
            return unsafe { on_avx2(work) };
        }
    }
    let _ = kernel; // only read on x86-64
    work.run::<ScalarRows>()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,avx2")]
unsafe fn on_avx2<W: LaneWork>(work: W) {
    work.run::<ScalarRows>()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,avx2,avx512f")]
unsafe fn on_avx512<W: LaneWork>(work: W) {
    // Rows move through AVX-512 registers: this function only runs where the CPU has it.
    work.run::<Avx512Rows>()
}
