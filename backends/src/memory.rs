//! How much memory this process may still use: the one place every size
//! check made before a large allocation compares its estimate with.
//!
//! Three ceilings, each read where the system has it (Linux `/proc` and
//! cgroup v2 files; none elsewhere, and then nothing is refused):
//! * the address-space limit `RLIMIT_AS` (`ulimit -v`) less the address
//!   space already mapped (`VmSize`, read after every rayon worker has
//!   started and allocated, so that their stacks and allocator arenas are
//!   in it whatever the timing) and a reserve of [`THREAD_RESERVE`] for one
//!   more thread (the main thread's or a progress reporter's);
//! * the cgroup's `memory.max` less its `memory.current`, the tightest of
//!   the process's cgroup and its ancestors;
//! * `MemAvailable` of `/proc/meminfo` (free memory plus what the kernel
//!   can reclaim without swapping).
//!
//! The smallest is the budget. Estimates are compared with it before any
//! of the memory they count is allocated; a refusal is one line naming the
//! estimate, the budget and which ceiling set it. An estimate is a bound on
//! the measured peak (each says how it was measured), not a guess: a run
//! under its budget does not stop half-way for want of memory, unless other
//! processes take the memory meanwhile.

use std::fmt;

/// Address space reserved for a thread not yet running when the budget is read
/// beyond the estimates: glibc gives each thread's allocations their own
/// 64 MiB arena of address space, and a thread has a 2 MiB stack and guard.
pub const THREAD_RESERVE: u64 = 72 << 20;

/// The memory this process may still use, and which ceiling says so.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Budget {
    /// Bytes.
    pub bytes: u64,
    /// The ceiling that set it, for messages (`"the address-space limit (ulimit -v)"`).
    pub source: &'static str,
}

/// An estimate over the [`Budget`]: refused before allocating.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OutOfMemory {
    /// What would have been made (`"torus:4096,2048"`).
    pub what: String,
    /// Estimated bytes (a bound on the peak).
    pub need: u64,
    /// What was left.
    pub budget: Budget,
}

impl fmt::Display for OutOfMemory {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} needs about {} MiB of memory but {} leaves {} MiB",
            self.what,
            self.need.div_ceil(1 << 20),
            self.budget.source,
            self.budget.bytes >> 20
        )
    }
}

impl std::error::Error for OutOfMemory {}

/// The tightest of the ceilings in the module docs, or `None` where the
/// system reports none.
#[must_use]
pub fn budget() -> Option<Budget> {
    let address = address_space_limit().map(|limit| {
        workers_started();
        Budget {
            bytes: limit.saturating_sub(address_space_used().unwrap_or(0)).saturating_sub(THREAD_RESERVE),
            source: "the address-space limit (ulimit -v)",
        }
    });
    let cgroup = cgroup_room().map(|bytes| Budget { bytes, source: "the cgroup's memory.max" });
    let free = meminfo("MemAvailable:").map(|bytes| Budget { bytes, source: "the free memory (MemAvailable)" });
    [address, cgroup, free].into_iter().flatten().min_by_key(|b| b.bytes)
}

/// Makes every worker of the current rayon pool run and allocate once, so
/// that `VmSize` holds their stacks and the 64 MiB arena glibc gives each
/// thread's first allocation. Read before they had all started, `VmSize`
/// varied by up to two arenas between runs of one command under one limit,
/// and the same run was refused or accepted by chance.
fn workers_started() {
    rayon::broadcast(|_| drop(std::hint::black_box(Box::new(0_u8))));
}

/// Refuses `need` bytes over the [`budget`]; `what` names the work for the
/// message (made only on refusal).
///
/// # Errors
/// [`OutOfMemory`] with the estimate and the budget.
pub fn check(what: impl FnOnce() -> String, need: u64) -> Result<(), OutOfMemory> {
    check_within(budget(), what, need)
}

/// [`check`] against a `budget` read once before a loop whose estimate
/// grows step by step (a scene reader's per-face count): reading it costs
/// a `rayon::broadcast` and four `/proc` and cgroup files, which once per
/// face of a 69k-triangle OBJ file took a quarter of a `viewpoints` run.
/// The budget read before the first allocation the estimate counts is the
/// right one to compare the whole estimate with.
///
/// # Errors
/// [`OutOfMemory`] naming `what` when `need` is over `budget`.
pub fn check_within(budget: Option<Budget>, what: impl FnOnce() -> String, need: u64) -> Result<(), OutOfMemory> {
    match budget {
        Some(budget) if need > budget.bytes => Err(OutOfMemory { what: what(), need, budget }),
        _ => Ok(()),
    }
}

/// Address space the obvhs BVH build takes at its peak per triangle, beyond
/// the scene and the tracer's triangles: the `VmPeak` of `itgfx complexity
/// torus:1024,512 --lines 100` (1.05 M triangles, debug build with the
/// tracer at opt-level 3) was 698,612 kB with `--backend cpu` and 473,352 kB
/// with `--backend reference` (no BVH): 220 B a triangle, rounded up.
pub const BVH_BUILD_BYTES_PER_TRIANGLE: u64 = 256;

/// Reserves `bytes` of address space and gives it back at once, so that
/// under an address-space limit (`ulimit -v`) an allocation of that size
/// fails here, as an error, and not later inside a library that panics or
/// aborts when an allocation fails (obvhs's BVH build, whose
/// `bytemuck::zeroed_vec` panics). The pages are never touched: this checks
/// the address space, not the physical memory the budget estimates bound.
///
/// # Errors
/// [`OutOfMemory`] naming `what` when the allocator refuses.
pub fn probe(what: impl FnOnce() -> String, bytes: u64) -> Result<(), OutOfMemory> {
    let mut v: Vec<u8> = Vec::new();
    let reserved = usize::try_from(bytes).ok().is_some_and(|len| v.try_reserve_exact(len).is_ok());
    if !reserved {
        return Err(OutOfMemory {
            what: what(),
            need: bytes,
            budget: budget().unwrap_or(Budget { bytes: 0, source: "the allocator" }),
        });
    }
    drop(v);
    Ok(())
}

/// A vector of `len` elements reserved up front, or [`OutOfMemory`] naming
/// `what` when the allocator refuses (a size that comes from input).
///
/// # Errors
/// [`OutOfMemory`] when the allocation fails.
pub fn try_vec<T>(len: usize, what: impl FnOnce() -> String) -> Result<Vec<T>, OutOfMemory> {
    let mut v = Vec::new();
    v.try_reserve_exact(len).map_err(|_| OutOfMemory {
        what: what(),
        need: (len as u64).saturating_mul(std::mem::size_of::<T>() as u64),
        budget: budget().unwrap_or(Budget { bytes: 0, source: "the allocator" }),
    })?;
    Ok(v)
}

/// Makes room in `v` for `more` elements, fallibly: the usual doubling,
/// but never a capacity past `most` (the bound the caller's memory
/// estimate counted), so that a vector growing towards its bound neither
/// aborts the process when memory runs out nor holds twice the estimate.
///
/// # Errors
/// The allocator's refusal.
pub fn try_grow<T>(v: &mut Vec<T>, more: usize, most: usize) -> Result<(), std::collections::TryReserveError> {
    let need = v.len().saturating_add(more);
    if need <= v.capacity() {
        return Ok(());
    }
    let want = need.max(v.capacity().saturating_mul(2).min(most));
    v.try_reserve_exact(want - v.len())
}

/// The soft `RLIMIT_AS` in bytes (`Max address space` of
/// `/proc/self/limits`); `None` when unlimited or unknown.
fn address_space_limit() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = text.lines().find(|l| l.starts_with("Max address space"))?;
    line["Max address space".len()..].split_whitespace().next()?.parse().ok()
}

/// Address space mapped now (`VmSize` of `/proc/self/status`), bytes.
fn address_space_used() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    kib_field(&text, "VmSize:")
}

/// A `Key:   N kB` field, in bytes.
fn kib_field(text: &str, key: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(key))?;
    let kib: u64 = line[key.len()..].split_whitespace().next()?.parse().ok()?;
    Some(kib.saturating_mul(1024))
}

/// A field of `/proc/meminfo`, bytes.
fn meminfo(key: &str) -> Option<u64> {
    kib_field(&std::fs::read_to_string("/proc/meminfo").ok()?, key)
}

/// `memory.max − memory.current` of this process's cgroup (v2) and each
/// ancestor that has a limit, the smallest; `None` when none has one.
fn cgroup_room() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let path = text.lines().find_map(|l| l.strip_prefix("0::"))?;
    let mut dir = std::path::PathBuf::from("/sys/fs/cgroup");
    dir.push(path.trim_start_matches('/'));
    let mut room: Option<u64> = None;
    loop {
        let read = |f: &str| std::fs::read_to_string(dir.join(f)).ok();
        if let Some(max) = read("memory.max").and_then(|s| s.trim().parse::<u64>().ok()) {
            let current = read("memory.current").and_then(|s| s.trim().parse::<u64>().ok()).unwrap_or(0);
            let r = max.saturating_sub(current);
            room = Some(room.map_or(r, |x| x.min(r)));
        }
        if dir == std::path::Path::new("/sys/fs/cgroup") || !dir.pop() {
            break;
        }
    }
    room
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn probe_refuses_what_cannot_be_reserved_and_gives_back_what_can() {
        // 2^62 bytes is past any x86-64 or AArch64 address space: refused,
        // as an error naming the work, not a panic or an abort.
        let e = probe(|| "the BVH over 2^54 triangles".into(), 1 << 62).unwrap_err();
        assert!(e.to_string().starts_with("the BVH over 2^54 triangles needs about"), "{e}");
        assert_eq!(e.need, 1 << 62);
        probe(|| unreachable!("64 MiB can be reserved"), 64 << 20).unwrap();
    }

    #[test]
    fn kib_fields_read_as_bytes() {
        let text = "Name:\titgfx\nVmSize:\t  123456 kB\nVmRSS:\t 10 kB\n";
        assert_eq!(kib_field(text, "VmSize:"), Some(123_456 * 1024));
        assert_eq!(kib_field(text, "VmPeak:"), None);
    }

    #[test]
    fn the_budget_is_below_the_free_memory_and_refuses_more() {
        let Some(b) = budget() else { return };
        if let Some(free) = meminfo("MemAvailable:") {
            assert!(b.bytes <= free, "{b:?} against {free}");
        }
        let e = check(|| "a test".into(), b.bytes.saturating_add(1 << 40)).unwrap_err();
        assert!(e.to_string().starts_with("a test needs about"), "{e}");
        assert!(check(|| unreachable!(), 0).is_ok());
    }

    #[test]
    fn try_grow_doubles_up_to_the_bound_only() {
        let mut v: Vec<u8> = Vec::new();
        try_grow(&mut v, 10, 100).unwrap();
        assert_eq!(v.capacity(), 10);
        v.extend([0; 10]);
        try_grow(&mut v, 1, 100).unwrap();
        assert_eq!(v.capacity(), 20);
        v.extend([0; 10]);
        try_grow(&mut v, 1, 25).unwrap();
        assert_eq!(v.capacity(), 25, "doubling stops at the bound");
        assert!(try_grow(&mut v, usize::MAX / 2, 25).is_err());
    }

    #[test]
    fn try_vec_refuses_what_the_allocator_cannot_give() {
        assert!(try_vec::<u64>(usize::MAX / 16, || "huge".into()).is_err());
        assert_eq!(try_vec::<u64>(10, || "small".into()).unwrap().capacity(), 10);
    }
}
