//! Counting the allocations of a piece of code: a global allocator that counts, per thread and
//! only while asked to, what the calling thread allocates. The one counter of the project: the
//! conformance suite's "forecast never allocates" check, the allocation-free test of the whole
//! forecast path (tests/alloc_free.rs) and the forecast-path table of `cargo bench --bench
//! hot_path` all use it. A binary opts in with
//!
//! ```text
//! #[global_allocator]
//! static ALLOCATOR: shipcast_predict::alloc_count::CountingAllocator =
//!     shipcast_predict::alloc_count::CountingAllocator;
//! ```
//!
//! Other threads (a retraining thread, zenoh's) are never counted, and a thread that is not
//! counting pays one thread-local check per allocation.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

/// The system allocator, counting the allocations (alloc, alloc_zeroed and realloc) of a
/// thread inside [`counted`].
pub struct CountingAllocator;

thread_local! {
    /// Counting is on for this thread.
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    /// Allocations made by this thread while counting.
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

fn note_allocation() {
    // `try_with`: a thread being torn down has no thread-locals left; it is not counting.
    let _ = COUNTING.try_with(|on| {
        if on.get() {
            let _ = ALLOCATIONS.try_with(|n| n.set(n.get() + 1));
        }
    });
}

// SAFETY: every call is passed on unchanged to the system allocator; the bookkeeping touches
// only const-initialised thread-locals without destructors, which never allocate.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note_allocation();
        // SAFETY: the caller's contract for `alloc` is passed on.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note_allocation();
        // SAFETY: as for `alloc`.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note_allocation();
        // SAFETY: `ptr` and `layout` come from this allocator, that is from `System`.
        unsafe { System.realloc(ptr, layout, new_size) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` and `layout` come from this allocator, that is from `System`.
        unsafe { System.dealloc(ptr, layout) }
    }
}

/// Run `f` and return its result with the number of allocations this thread made in it. Counts
/// only in a binary whose global allocator is [`CountingAllocator`] (elsewhere: always 0).
pub fn counted<T>(f: impl FnOnce() -> T) -> (T, u64) {
    let outer = COUNTING.with(|on| on.replace(true));
    let before = ALLOCATIONS.with(Cell::get);
    let out = f();
    let after = ALLOCATIONS.with(Cell::get);
    COUNTING.with(|on| on.set(outer));
    (out, after - before)
}
