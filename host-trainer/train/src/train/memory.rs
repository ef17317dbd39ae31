//! The trainer's one `unsafe` block: glibc's `mallopt`, so that a training step does not
//! fault its tensors in again (measured: `docs/host-speed.md`). Nothing else in the trainer
//! calls foreign code.
#![allow(unsafe_code)]

/// Asks the C allocator to keep freed memory in the process: no trimming of the heap and no
/// separately mapped blocks below 32 MiB (glibc's `mallopt`; elsewhere a no-op).
///
/// A training step allocates and frees about a hundred tensors of up to a few MiB (candle's
/// outputs and zero-filled gradient accumulators). With glibc's defaults the freed memory goes
/// back to the kernel and the next step faults it in again, page by page: before this setting a
/// paper-size epoch spent about 18 % of its time in page faults, `brk` and `munmap`. Memory
/// stays at the run's peak instead. Allocation never changes a computed bit.
pub fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        // glibc's `mallopt` parameters (malloc.h).
        const M_TRIM_THRESHOLD: std::ffi::c_int = -1;
        const M_MMAP_THRESHOLD: std::ffi::c_int = -3;
        extern "C" {
            fn mallopt(param: std::ffi::c_int, value: std::ffi::c_int) -> std::ffi::c_int;
        }
        // SAFETY: `mallopt` only sets allocator parameters (it takes the allocator's own lock)
        // and reports an unsupported value by returning 0, which is ignored: the defaults then
        // stay, which is correct, only slower. 32 MiB is glibc's largest mmap threshold on
        // 64-bit targets.
        unsafe {
            mallopt(M_TRIM_THRESHOLD, 1 << 30);
            mallopt(M_MMAP_THRESHOLD, 32 << 20);
        }
    }
}
