//! The memory bound: a global allocator that counts the heap bytes in use
//! and stops the process, with a message and exit code 3, when an
//! allocation would take them past the limit (`--max-memory`, by default
//! half the RAM). Validation's estimates refuse what is too big before
//! anything runs ([`crate::resources`]); this bound holds for everything
//! the estimates do not see — imports, parallel stages (`-j`), the slack of
//! an estimate — so `--max-memory` bounds the run, not only its plan.
//!
//! Stopping is like a kill: the cache is written atomically (objects
//! first, record last), so nothing wrong is cached and the next run
//! cleans up the temp files. The count is of heap bytes asked for (what
//! the allocator hands out); the resident set adds the program, stacks
//! and the allocator's own slack, a few MiB.
//!
//! The binary installs it (`main.rs`); the library and its tests run on
//! the system allocator.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

/// The least heap the bound allows, whatever `--max-memory` says: the
/// program's own working room (parsing a pipeline, reporting). A smaller
/// `--max-memory` still applies in full to validation's estimates.
pub const FLOOR: usize = 32 << 20;

/// The system allocator with a count of live bytes and a limit.
pub struct Bounded {
    used: AtomicUsize,
    /// 0: no limit (before the command line is read).
    limit: AtomicUsize,
}

impl Bounded {
    pub const fn new() -> Bounded {
        Bounded {
            used: AtomicUsize::new(0),
            limit: AtomicUsize::new(0),
        }
    }

    /// Set the limit in bytes (0: none); never below [`FLOOR`].
    pub fn set_limit(&self, bytes: u64) {
        let bytes = usize::try_from(bytes).unwrap_or(usize::MAX).max(FLOOR);
        self.limit.store(bytes, Ordering::Relaxed);
    }

    /// Heap bytes in use now.
    pub fn used(&self) -> usize {
        self.used.load(Ordering::Relaxed)
    }

    /// Count `size` more bytes; stop the process when that passes the limit.
    fn take(&self, size: usize) {
        let before = self.used.fetch_add(size, Ordering::Relaxed);
        let limit = self.limit.load(Ordering::Relaxed);
        if limit != 0 && before.saturating_add(size) > limit {
            stop(limit, before, size);
        }
    }
}

impl Default for Bounded {
    fn default() -> Self {
        Bounded::new()
    }
}

// SAFETY: every call is forwarded to `System` with the caller's layout and
// pointer unchanged; the count is bookkeeping only.
unsafe impl GlobalAlloc for Bounded {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        self.take(layout.size());
        System.alloc(layout)
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        self.take(layout.size());
        System.alloc_zeroed(layout)
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        self.used.fetch_sub(layout.size(), Ordering::Relaxed);
        System.dealloc(ptr, layout)
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > layout.size() {
            self.take(new_size - layout.size());
        } else {
            self.used
                .fetch_sub(layout.size() - new_size, Ordering::Relaxed);
        }
        System.realloc(ptr, layout, new_size)
    }
}

extern "C" {
    /// POSIX `_exit`: ends the process at once, without running exit
    /// handlers (which might allocate, or wait on a lock another thread
    /// holds while it allocates).
    fn _exit(code: i32) -> !;
}

/// Print why and leave with exit code 3 (see `cli::exit::ERROR`), without
/// allocating: the allocator is where we are.
fn stop(limit: usize, used: usize, asked: usize) -> ! {
    use std::io::Write;
    let mut buf = [0u8; 512];
    let mut w = Cursor {
        buf: &mut buf,
        len: 0,
    };
    w.put(b"modalflow: the memory limit of ");
    w.mib(limit);
    w.put(b" (--max-memory) is reached: an allocation of ");
    w.mib(asked);
    w.put(b" with ");
    w.mib(used);
    w.put(b" in use\n  = help: raise --max-memory (or MODALFLOW_MAX_MEMORY), run fewer stages at once (-j 1), or make the stage smaller; nothing was cached for the unfinished stages\n");
    let len = w.len;
    let _ = std::io::stderr().write_all(&buf[..len]);
    // SAFETY: `_exit` takes an exit status and does not return.
    unsafe { _exit(3) }
}

/// A fixed buffer written without allocating.
struct Cursor<'a> {
    buf: &'a mut [u8],
    len: usize,
}

impl Cursor<'_> {
    fn put(&mut self, bytes: &[u8]) {
        let n = bytes.len().min(self.buf.len() - self.len);
        self.buf[self.len..self.len + n].copy_from_slice(&bytes[..n]);
        self.len += n;
    }

    /// `bytes` as whole MiB (at least 1 when non-zero) and the unit.
    fn mib(&mut self, bytes: usize) {
        let mut v = bytes.div_ceil(1 << 20);
        let mut digits = [0u8; 20];
        let mut i = digits.len();
        loop {
            i -= 1;
            digits[i] = b'0' + (v % 10) as u8;
            v /= 10;
            if v == 0 {
                break;
            }
        }
        let text = digits;
        self.put(&text[i..]);
        self.put(b" MiB");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_live_bytes_through_alloc_realloc_and_dealloc() {
        let heap = Bounded::new();
        let layout = Layout::from_size_align(1000, 8).unwrap();
        unsafe {
            let p = heap.alloc(layout);
            assert_eq!(heap.used(), 1000);
            let q = heap.realloc(p, layout, 5000);
            assert_eq!(heap.used(), 5000);
            let q = heap.realloc(q, Layout::from_size_align(5000, 8).unwrap(), 200);
            assert_eq!(heap.used(), 200);
            heap.dealloc(q, Layout::from_size_align(200, 8).unwrap());
        }
        assert_eq!(heap.used(), 0);
    }

    #[test]
    fn the_message_is_formatted_without_allocating() {
        let mut buf = [0u8; 64];
        let mut w = Cursor {
            buf: &mut buf,
            len: 0,
        };
        w.mib(256 << 20);
        w.put(b", ");
        w.mib(1);
        w.put(b", ");
        w.mib(0);
        let len = w.len;
        assert_eq!(&buf[..len], b"256 MiB, 1 MiB, 0 MiB");
    }
}
