//! Running the `ispm` binary as a user does.

use std::path::Path;
use std::process::{Command, Output};

/// Runs the `ispm` binary with validation on.
pub fn ispm(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ispm"))
        .args(args)
        .env("ISPM_VALIDATION", "1")
        .output()
        .expect("run ispm")
}

/// Asserts a failure with exactly one line on stderr that mentions `needle`, no panic, and no
/// file at `output`.
pub fn assert_clean_failure(out: &Output, needle: &str, output: &Path) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success(),
        "expected failure, got success: {stderr}"
    );
    assert!(
        !stderr.contains("panicked") && !stderr.contains("internal error"),
        "panic: {stderr}"
    );
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "expected one line, got:\n{stderr}");
    assert!(lines[0].starts_with("ispm: "), "{stderr}");
    assert!(
        lines[0].contains(needle),
        "expected {needle:?} in: {stderr}"
    );
    assert!(!output.exists(), "{} was written", output.display());
    let leftovers: Vec<_> = std::fs::read_dir(output.parent().expect("parent"))
        .expect("dir")
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
}
