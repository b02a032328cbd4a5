//! The command line's allocator: the system's, with every large block
//! advised to the kernel as one for transparent huge pages.
//!
//! The engines' large buffers (the scene channel's pair matrix and per-block
//! pair lists, the viewpoint channel's entries, images) are written once,
//! soon after they are allocated. With 4 KiB pages each page of a fresh
//! mapping costs a fault on its first write (the kernel's fault path, its
//! accounting and zeroing): about 0.3 s of system time in a 10^7-line
//! `complexity` run that touches ~420 MB, an eighth of its CPU time
//! (docs/TRACING.md, *Huge pages*). Where the kernel runs transparent huge
//! pages in `madvise` mode (the common default), a block advised with
//! `MADV_HUGEPAGE` is faulted 2 MiB at a time instead, which is what
//! glibc's own `glibc.malloc.hugetlb=1` tunable does; this allocator does it
//! without the environment variable. Elsewhere (not Linux, or huge pages
//! off) the advice is ignored and nothing changes. The numbers an engine
//! computes never depend on where its memory lies.

use std::alloc::{GlobalAlloc, Layout, System};

/// The system allocator, with each block of [`HUGE_MIN`] bytes or more
/// advised for transparent huge pages (see the module docs).
pub struct HugePages;

/// Smallest block worth advising: one huge page (2 MiB on x86-64 and most
/// arm64 kernels). A smaller block cannot hold a whole aligned huge page.
pub const HUGE_MIN: usize = 2 << 20;

// SAFETY: every method forwards to `System` with the caller's arguments
// unchanged and returns its result unchanged; the advice given afterwards
// neither moves, frees nor changes the contents of any memory.
unsafe impl GlobalAlloc for HugePages {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's contract for `GlobalAlloc::alloc`, passed on.
        let p = unsafe { System.alloc(layout) };
        advise(p, layout.size());
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's contract for `GlobalAlloc::alloc_zeroed`, passed on.
        let p = unsafe { System.alloc_zeroed(layout) };
        advise(p, layout.size());
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: the caller's contract for `GlobalAlloc::dealloc`, passed on:
        // `ptr` came from this allocator, that is from `System`.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: the caller's contract for `GlobalAlloc::realloc`, passed on.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        advise(p, new_size);
        p
    }
}

/// Advises the whole pages inside `[p, p + len)` for huge pages, if `len`
/// is at least [`HUGE_MIN`] (a null `p`, a failed allocation, is left
/// alone). The advice is a hint: its result is ignored, since a kernel
/// without transparent huge pages refuses it and the block works the same.
#[inline]
fn advise(p: *mut u8, len: usize) {
    #[cfg(target_os = "linux")]
    if len >= HUGE_MIN && !p.is_null() {
        const PAGE: usize = 4096;
        let start = (p as usize).next_multiple_of(PAGE);
        let end = (p as usize + len) / PAGE * PAGE;
        if end > start {
            // SAFETY: `[start, end)` lies inside the block just allocated
            // (whole pages of it, mapped: the allocator owns them), and
            // MADV_HUGEPAGE only sets a flag on those pages' mapping: it
            // reads, writes and frees nothing, and fails harmlessly
            // (EINVAL) where transparent huge pages are not built in.
            unsafe { libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE) };
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = (p, len);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn large_and_small_blocks_keep_their_contents_through_realloc() {
        for size in [64, HUGE_MIN - 1, HUGE_MIN, 3 * HUGE_MIN + 17] {
            let layout = Layout::from_size_align(size, 16).expect("valid layout");
            // SAFETY: a non-zero size; the block is freed below with the
            // layout realloc returned it under.
            unsafe {
                let p = HugePages.alloc_zeroed(layout);
                assert!(!p.is_null());
                assert!(std::slice::from_raw_parts(p, size).iter().all(|&b| b == 0));
                for k in 0..size {
                    p.add(k).write(k as u8);
                }
                let q = HugePages.realloc(p, layout, 2 * size);
                assert!(!q.is_null());
                assert!((0..size).all(|k| q.add(k).read() == k as u8));
                HugePages.dealloc(q, Layout::from_size_align(2 * size, 16).expect("valid layout"));
            }
        }
    }
}
