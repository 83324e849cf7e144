//! Shared helpers for the host tests live in the test files; this crate has no library code.
