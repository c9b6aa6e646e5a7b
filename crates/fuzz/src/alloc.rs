//! A global allocator that counts live heap bytes, so a campaign can bound
//! each input's memory (the promise: a small input never takes the machine).
//!
//! Every fuzz binary installs [`Counting`]; [`reset_peak`] before an input
//! and [`peak`] after it give the most bytes live while it ran. Past
//! [`HARD_LIMIT`] an allocation fails (the process aborts with Rust's "memory
//! allocation failed" message) rather than taking a shared machine down; the
//! input that did it is in the campaign's `current` file.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

/// Live bytes above which any allocation fails.
pub const HARD_LIMIT: usize = 6 << 30;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

/// The system allocator, counting.
pub struct Counting;

// SAFETY: every call forwards to `System` with the same arguments; the counters
// are plain atomics and never allocate.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: forwarded unchanged.
        counted(layout.size(), || unsafe { System.alloc(layout) })
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: forwarded unchanged.
        counted(layout.size(), || unsafe { System.alloc_zeroed(layout) })
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
        // SAFETY: forwarded unchanged.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > layout.size() && !grow(new_size - layout.size()) {
            return std::ptr::null_mut();
        }
        // SAFETY: forwarded unchanged.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if p.is_null() {
            if new_size > layout.size() {
                LIVE.fetch_sub(new_size - layout.size(), Ordering::Relaxed);
            }
        } else if new_size < layout.size() {
            LIVE.fetch_sub(layout.size() - new_size, Ordering::Relaxed);
        }
        p
    }
}

/// Counts `size` live bytes around an allocation: none is made past
/// [`HARD_LIMIT`], and a failed one is uncounted.
fn counted(size: usize, allocate: impl FnOnce() -> *mut u8) -> *mut u8 {
    if !grow(size) {
        return std::ptr::null_mut();
    }
    let p = allocate();
    if p.is_null() {
        LIVE.fetch_sub(size, Ordering::Relaxed);
    }
    p
}

/// Counts `n` more live bytes, unless that passes [`HARD_LIMIT`].
fn grow(n: usize) -> bool {
    let live = LIVE.fetch_add(n, Ordering::Relaxed) + n;
    if live > HARD_LIMIT {
        LIVE.fetch_sub(n, Ordering::Relaxed);
        return false;
    }
    PEAK.fetch_max(live, Ordering::Relaxed);
    true
}

/// Bytes live now.
#[must_use]
pub fn live() -> usize {
    LIVE.load(Ordering::Relaxed)
}

/// Starts a new peak measurement from the bytes live now.
pub fn reset_peak() {
    PEAK.store(LIVE.load(Ordering::Relaxed), Ordering::Relaxed);
}

/// Most bytes live since [`reset_peak`].
#[must_use]
pub fn peak() -> usize {
    PEAK.load(Ordering::Relaxed)
}
