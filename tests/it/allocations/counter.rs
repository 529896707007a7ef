//! A global allocator that counts allocations, globally and per thread, so that a
//! test binary can assert a code path allocates nothing. Include it with `#[path]`
//! in a test binary of its own: it sees every thread, so no other test may run
//! beside it.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

pub struct CountingAllocator;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);
thread_local! {
    // Allocations made by this thread (const-initialised: reading it never allocates).
    static THIS_THREAD: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        THIS_THREAD.with(|c| c.set(c.get() + 1));
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

/// `(allocations by every thread, allocations by this thread)` so far.
fn counts() -> (usize, usize) {
    (
        ALLOCATIONS.load(Ordering::SeqCst),
        THIS_THREAD.with(|c| c.get()),
    )
}

/// Windows [`allocations_of`] runs its work in.
const WINDOWS: usize = 4;

/// Allocations made while `work` runs, as `(by all threads, by the calling
/// thread)` in the quietest of a few runs.
///
/// The thread pool allocates now and then on its own account, at moments the
/// scheduler picks: each worker once for itself (thread-locals, its job queue),
/// and the queue of jobs handed in from outside the pool a new block every few
/// dozen jobs. Such one-off allocations spoil one run each at most, so the
/// quietest run counts the work's own allocations, while an allocation the work
/// makes on every run shows in all of them. Every worker is made to run a job
/// first, which leaves little to spoil a run in the first place.
pub fn allocations_of(mut work: impl FnMut()) -> (usize, usize) {
    rayon::broadcast(|_| ());
    (0..WINDOWS)
        .map(|_| {
            let (before, before_here) = counts();
            work();
            let (after, after_here) = counts();
            (after - before, after_here - before_here)
        })
        .min()
        .expect("at least one run")
}
