//! Host memory of the viewer process, to check that switching pipelines and
//! options again and again leaves it flat.

/// The resident set size of this process in KiB (`VmRSS` in
/// `/proc/self/status`); `None` where that file does not exist.
pub fn resident_kib() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

#[cfg(test)]
mod tests {
    #[test]
    fn reads_a_resident_size_on_linux() {
        if cfg!(target_os = "linux") {
            assert!(super::resident_kib().is_some_and(|kib| kib > 0));
        }
    }
}
