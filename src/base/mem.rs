//! The process's memory: its peak as the system counts it, and cache hints.

/// The process's peak resident memory so far in MiB (Linux `VmHWM` of
/// `/proc/self/status`; `None` elsewhere). Every stage's memory figure is read here.
pub fn peak_rss_mib() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

/// A hint to load the cache line holding the start of `x` (no-op where the target has no
/// prefetch instruction). Only a hint: it reads nothing architecturally and changes no
/// result, so loops that walk random indices can ask for the next items' lines while they
/// work on the current one.
#[inline(always)]
pub fn prefetch<T>(x: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch never faults and has no architectural effect; the pointer comes
    // from a reference, so it is valid anyway.
    unsafe {
        std::arch::x86_64::_mm_prefetch(x as *const T as *const i8, std::arch::x86_64::_MM_HINT_T0);
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = x;
}

/// [`prefetch`] of every cache line `x` spans (a value may cross a line boundary).
#[inline(always)]
pub fn prefetch_all<T>(x: &T) {
    prefetch(x);
    #[cfg(target_arch = "x86_64")]
    {
        let p = x as *const T as *const u8;
        let mut off = 64 - (p as usize & 63);
        while off < size_of::<T>() {
            // SAFETY: `p + off` lies inside the value `x` refers to (`off < size_of::<T>()`);
            // a prefetch does not access memory architecturally.
            unsafe { std::arch::x86_64::_mm_prefetch(p.add(off) as *const i8, std::arch::x86_64::_MM_HINT_T0) };
            off += 64;
        }
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_peak_is_read_on_linux() {
        if cfg!(target_os = "linux") {
            let m = super::peak_rss_mib().expect("VmHWM on Linux");
            assert!(m > 0.0 && m.is_finite(), "{m}");
        }
    }
}
