//! The files a command reads and writes, under one rule: an output is never an input of the
//! same command, nor another of its outputs (the same file is found by canonical path and, when
//! it exists, by device and inode, so `./a`, `dir/../a` and a hard link are all caught); the
//! outputs are staged beside their destinations and renamed into place together once every one
//! is written, so a failed command leaves none; and a staging file that a killed run left behind
//! (`.calflash-<pid>-*.tmp`, its process gone) is removed the first time a command writes into
//! that directory (once per directory and process, so a batch of thousands of units reads its
//! folder once, not once per file).
//!
//! An output that exists and is not a regular file (a device such as `/dev/null`, `/dev/stdout`,
//! a FIFO, a socket) is never renamed over: a rename would replace the device with a file (run
//! as root, `--json /dev/null` would break every other program on the machine). Its bytes are
//! held until the commit and written into it in place. An output that is a symbolic link to a
//! file is staged beside the link's target and replaces the target, so the link stays.
//!
//! A file a unit's serial names ([`unit_file`]) is made only of a serial that is a safe file
//! name: no separator, no `..`, nothing hidden, so a serial cannot write outside its folder.

mod lock;
mod paths;
mod read;
mod staged;

use std::path::PathBuf;

pub use lock::{FolderLock, LOCK_FILE, folder_of};
pub use paths::{Paths, resolutions, same_file};
pub use read::{LineBound, MAX_JSON, is_special, read_blob, read_bounded, read_json_text};
pub use staged::{Staged, unit_file, write_atomically};

/// Why a command's files cannot be used as given, or an output cannot be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A folder another command is writing into.
    #[error("{what} {}: another calflash is writing there ({holder}); one writer at a time, so that no unit's files come from two runs: wait for it to finish or write elsewhere", .dir.display())]
    Locked {
        /// The option that writes there.
        what: String,
        /// The folder.
        dir: PathBuf,
        /// The holder, as its lock file names it.
        holder: String,
    },
    /// An output's directory does not exist (and the command does not create it).
    #[error("{what} {}: the directory {} does not exist; create it first", .path.display(), .dir.display())]
    NoDirectory {
        /// The option that gave it.
        what: String,
        /// The output.
        path: PathBuf,
        /// Its directory.
        dir: PathBuf,
    },
    /// An output that is a directory.
    #[error("{what} {}: that is a directory; give a file name", .path.display())]
    IsDirectory {
        /// The option that gave it.
        what: String,
        /// The output.
        path: PathBuf,
    },
    /// An output that is one of the command's inputs.
    #[error("{what} {}: that is the file {input} reads; the command would replace its own input", .path.display())]
    ReplacesInput {
        /// The option that gave the output.
        what: String,
        /// The output.
        path: PathBuf,
        /// The option that gave the input.
        input: String,
    },
    /// Two inputs that must be two files (the two records compared, the two sensors' recordings)
    /// and are one.
    #[error("{what} {} and {other} name one file: each must be its own", .path.display())]
    SameInput {
        /// The option that gave the input.
        what: String,
        /// The input.
        path: PathBuf,
        /// The option that gave the other.
        other: String,
    },
    /// Two outputs that are one file.
    #[error("{what} {} and {other} name one file: give each output its own path", .path.display())]
    SameOutput {
        /// The option that gave the output.
        what: String,
        /// The output.
        path: PathBuf,
        /// The option that gave the other.
        other: String,
    },
    /// A unit's serial that cannot name a file.
    #[error(
        "unit `{serial}`: a serial that names a file must be a plain file name: letters, digits, \
         `-`, `_`, `+` and `.`, not starting with `.` (it would write {})",
        .path.display()
    )]
    UnsafeSerial {
        /// The serial.
        serial: String,
        /// The file it would have named.
        path: PathBuf,
    },
    /// An input longer than any file of its kind can be.
    #[error("{}: longer than {max} bytes: not {what}", .path.display())]
    TooLong {
        /// The input.
        path: PathBuf,
        /// The most its kind holds.
        max: u64,
        /// What it should be.
        what: &'static str,
    },
    /// Reading an input failed.
    #[error("{}: {source}", .path.display())]
    Read {
        /// The input.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// Writing or renaming an output failed.
    #[error("{}: {source}", .path.display())]
    Io {
        /// The output.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    #[test]
    fn one_file_under_two_names_is_caught() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.csv");
        std::fs::write(&a, "x").unwrap();
        let link = dir.path().join("link.csv");
        std::fs::hard_link(&a, &link).unwrap();
        let dotted = dir.path().join(".").join("a.csv");
        for out in [&a, &link, &dotted] {
            let e = Paths::new()
                .input("the data", Some(&a))
                .output("--blob", Some(out))
                .check()
                .unwrap_err();
            let e = e.to_string();
            assert!(e.contains("--blob") && e.contains("the data reads"), "{e}");
        }
        // Two outputs, one not yet existing.
        let n = dir.path().join("new.json");
        let e = Paths::new()
            .output("--blob", Some(&n))
            .output("--json", Some(&dir.path().join("sub/../new.json")))
            .check()
            .unwrap_err();
        // `sub` does not exist, so that output cannot be written at all.
        assert!(e.to_string().contains("sub/.. does not exist"), "{e}");
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        let e = Paths::new()
            .output("--blob", Some(&n))
            .output("--json", Some(&dir.path().join("sub/../new.json")))
            .check()
            .unwrap_err();
        let e = e.to_string();
        assert!(e.contains("--json") && e.contains("--blob"), "{e}");
        assert!(
            Paths::new()
                .input("the data", Some(&a))
                .output("-o", Some(&n))
                .check()
                .is_ok()
        );
    }

    #[test]
    fn two_inputs_that_must_differ_are_refused_when_one_file() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("acc.txt");
        std::fs::write(&a, "x").unwrap();
        let dotted = dir.path().join(".").join("acc.txt");
        let e = Paths::new()
            .distinct_input("the recording", Some(&a))
            .distinct_input("--gyro", Some(&dotted))
            .check()
            .unwrap_err()
            .to_string();
        assert!(e.contains("--gyro") && e.contains("the recording"), "{e}");
        // Inputs that may be one file (a blob read twice) are not refused.
        assert!(
            Paths::new()
                .input("--blob", Some(&a))
                .input("the data", Some(&a))
                .check()
                .is_ok()
        );
    }

    #[test]
    fn a_failed_stage_leaves_nothing_and_stale_files_go() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out.csv");
        let mut s = Staged::new();
        s.write(&out, |w| w.write_all(b"1")).unwrap();
        let e = s.write(&dir.path().join("missing/x.html"), |w| w.write_all(b"2"));
        assert!(e.is_err());
        drop(s);
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        // A killed run's staging file (a process that cannot exist) is removed by the first
        // write of this process into its directory.
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out.csv");
        let stale = dir.path().join(".calflash-4294967-abc.tmp");
        std::fs::write(&stale, "half").unwrap();
        write_atomically(&out, |w| w.write_all(b"done")).unwrap();
        assert!(!stale.exists());
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "done");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        // The directory is read once per process: a later write does not read it again.
        std::fs::write(&stale, "half").unwrap();
        write_atomically(&out, |w| w.write_all(b"again")).unwrap();
        assert!(stale.exists(), "the folder was read a second time");
    }

    #[test]
    fn a_special_file_is_written_in_place_never_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if !made.is_ok_and(|s| s.success()) {
            eprintln!("skipped: mkfifo is not available here");
            return;
        }
        // A link to the FIFO, as /dev/stdout is a link to the process's pipe.
        let link = dir.path().join("stdout");
        std::os::unix::fs::symlink(&fifo, &link).unwrap();
        for out in [&fifo, &link] {
            let reader = {
                let fifo = fifo.clone();
                std::thread::spawn(move || std::fs::read(fifo).unwrap())
            };
            write_atomically(out, |w| w.write_all(b"through the pipe")).unwrap();
            assert_eq!(reader.join().unwrap(), b"through the pipe");
            let m = std::fs::metadata(&fifo).unwrap();
            assert!(!m.is_file(), "the FIFO was replaced by a file");
            assert!(
                std::fs::symlink_metadata(&link)
                    .unwrap()
                    .file_type()
                    .is_symlink()
            );
        }
        // Two outputs into one special file are no conflict; into one regular file they are.
        assert!(is_special(Path::new("/dev/null")));
        assert!(
            Paths::new()
                .output("-o", Some(Path::new("/dev/null")))
                .output("--json", Some(Path::new("/dev/null")))
                .check()
                .is_ok()
        );
    }

    #[test]
    fn a_link_to_a_file_keeps_the_link_and_replaces_its_target() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("real.json");
        std::fs::write(&target, "old").unwrap();
        let link = dir.path().join("link.json");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        write_atomically(&link, |w| w.write_all(b"new")).unwrap();
        assert!(
            std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "new");
    }

    #[test]
    fn reads_are_bounded() {
        let e = read_blob(Path::new("/dev/zero")).unwrap_err();
        assert!(
            matches!(e, Error::TooLong { max, .. } if max == spincal::signed::MAX_SIGNED_LEN as u64)
        );
        assert!(e.to_string().contains("not a calibration blob"), "{e}");
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("b");
        std::fs::write(&p, [7u8; 10]).unwrap();
        assert_eq!(read_bounded(&p, 10, "ten").unwrap().len(), 10);
        assert!(read_bounded(&p, 9, "nine").is_err());
    }

    #[test]
    fn a_line_too_long_is_refused_naming_it() {
        use std::io::Read as _;
        let mut ok = String::new();
        LineBound::new(&b"ab\ncd\n"[..], 2)
            .read_to_string(&mut ok)
            .unwrap();
        assert_eq!(ok, "ab\ncd\n");
        let mut s = String::new();
        let e = LineBound::new(&b"ab\ncde\n"[..], 2)
            .read_to_string(&mut s)
            .unwrap_err();
        assert!(
            e.to_string().contains("line 2 is longer than 2 bytes"),
            "{e}"
        );
    }

    /// Reads `text` through a [`LineBound`] in reads of `chunk` bytes.
    fn through(text: &[u8], chunk: usize) -> Vec<u8> {
        use std::io::Read as _;
        let mut r = LineBound::new(text, 100);
        let (mut out, mut buf) = (Vec::new(), vec![0; chunk]);
        loop {
            let n = r.read(&mut buf).unwrap();
            if n == 0 {
                return out;
            }
            out.extend_from_slice(&buf[..n]);
        }
    }

    #[test]
    fn a_crlf_line_ending_is_read_as_lf_and_a_lone_cr_kept() {
        let text = b"a,b\r\n1,2\r\n\r\n3\r4\r\n\r";
        for chunk in [1, 2, 3, 64] {
            assert_eq!(through(text, chunk), b"a,b\n1,2\n\n3\r4\n\r", "{chunk}");
        }
    }

    #[test]
    fn a_crlf_table_names_the_right_line() {
        // The csv crate alone counts a CRLF file's third line as its second.
        let text = "t,x\r\n1,2\r\n3,no\r\n";
        let mut reader = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .from_reader(LineBound::new(text.as_bytes(), 100));
        let mut lines = Vec::new();
        for r in reader.records() {
            let r = r.unwrap();
            lines.push((r.position().unwrap().line(), r.get(1).unwrap().to_string()));
        }
        assert_eq!(lines, [(2, "2".into()), (3, "no".into())]);
    }

    #[test]
    fn a_serial_names_a_file_only_when_it_is_a_plain_name() {
        let dir = Path::new("out");
        assert_eq!(
            unit_file(dir, "IMU-0007_b+2.1", "blob").unwrap(),
            Path::new("out/IMU-0007_b+2.1.blob")
        );
        for bad in [
            "../x", "/tmp/x", "a/b", "..", ".hidden", "", "a b", "a\\b", "a:b",
        ] {
            let e = unit_file(dir, bad, "blob").unwrap_err();
            assert!(
                matches!(&e, Error::UnsafeSerial { serial, .. } if serial == bad),
                "{bad}"
            );
            assert!(e.to_string().contains("plain file name"), "{e}");
        }
    }
}
