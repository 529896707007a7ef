//! A global allocator that counts the allocations of measured threads only, so that a
//! test can assert a code path allocates nothing while other tests of the binary run
//! beside it: [`allocations_of`] runs the work on a thread pool of its own whose
//! threads are measured, and no other thread is.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

pub struct CountingAllocator;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);
thread_local! {
    // Both const-initialised: reading them never allocates.
    static MEASURED: Cell<bool> = const { Cell::new(false) };
    static THIS_THREAD: Cell<usize> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if MEASURED.with(Cell::get) {
            ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
            THIS_THREAD.with(|c| c.set(c.get() + 1));
        }
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

/// `(allocations by every measured thread, allocations by this thread)` so far.
fn counts() -> (usize, usize) {
    (
        ALLOCATIONS.load(Ordering::SeqCst),
        THIS_THREAD.with(|c| c.get()),
    )
}

/// Windows [`allocations_of`] runs its work in.
const WINDOWS: usize = 4;

/// Measurements take turns: the counter of measured threads is shared.
static TURN: Mutex<()> = Mutex::new(());

/// Allocations made while `work` runs, as `(by all threads of the work's pool, by the
/// thread that runs `work`)` in the quietest of a few runs.
///
/// The work runs inside a thread pool of its own, as many threads as the global one,
/// whose threads (and only they) are measured: the batch's parallel steps go to the
/// current pool. The pool allocates now and then on its own account, at moments the
/// scheduler picks: each worker once for itself (thread-locals, its job queue). Such
/// one-off allocations spoil one run each at most, so the quietest run counts the
/// work's own allocations, while an allocation the work makes on every run shows in all
/// of them. Every worker is made to run a job first, which leaves little to spoil a run
/// in the first place.
pub fn allocations_of(mut work: impl FnMut() + Send) -> (usize, usize) {
    let _turn = TURN.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(rayon::current_num_threads())
        .start_handler(|_| MEASURED.with(|m| m.set(true)))
        .build()
        .expect("a thread pool for the measurement");
    pool.install(|| {
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
    })
}
