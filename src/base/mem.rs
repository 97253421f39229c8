//! The process's memory, as the system counts it.

/// The process's peak resident memory so far in MiB (Linux `VmHWM` of
/// `/proc/self/status`; `None` elsewhere). Every stage's memory figure is read here.
pub fn peak_rss_mib() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
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
