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
pub fn counts() -> (usize, usize) {
    (
        ALLOCATIONS.load(Ordering::SeqCst),
        THIS_THREAD.with(|c| c.get()),
    )
}
