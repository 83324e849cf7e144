//! Free space on the disk the builds write to: a full disk fails a build with a linker crash
//! that names nothing, so `xtask test` says how much there was before and after.

use std::path::Path;
use std::process::Command;

/// About what a fresh `cargo xtask test` writes under `target/`, `firmware/target/` and
/// `fuzz/target/` (measured on a fresh clone, 2026-11-24: 3.2 + 1.4 + 0.5 GB, rounded up).
pub const NEEDED_BYTES: u64 = 6 << 30;

/// Bytes free on the file system holding `path`, from POSIX `df -Pk`; `None` when `df` is
/// missing or prints something else.
pub fn free_bytes(path: &Path) -> Option<u64> {
    let out = Command::new("df").arg("-Pk").arg(path).output().ok()?;
    if !out.status.success() {
        return None;
    }
    parse_df(&String::from_utf8_lossy(&out.stdout))
}

/// The "Available" column (KiB) of `df -P`'s one data line, in bytes.
fn parse_df(text: &str) -> Option<u64> {
    let line = text.lines().nth(1)?;
    let kib: u64 = line.split_whitespace().nth(3)?.parse().ok()?;
    Some(kib * 1024)
}

/// `12.3 GB`, for people.
pub fn human(bytes: u64) -> String {
    format!("{:.1} GB", bytes as f64 / f64::from(1u32 << 30))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_the_available_column_of_df_p() {
        let text = "Filesystem     1024-blocks      Used Available Capacity Mounted on\n\
                    /dev/vda         264091588  76123456  19876543      80% /\n";
        assert_eq!(parse_df(text), Some(19_876_543 * 1024));
        assert_eq!(parse_df("Filesystem\n"), None);
        assert_eq!(parse_df("header\n/dev/vda 1 2 lots 4% /\n"), None);
    }

    #[test]
    fn human_reads_gigabytes() {
        assert_eq!(human(3 << 30), "3.0 GB");
        assert_eq!(human(1 << 29), "0.5 GB");
    }
}
