//! The documentation stays readable: every Markdown file of `docs/` and the README is of a
//! size a person reads, repeats no paragraph line many times over, and links only pictures that
//! exist. (An edit that replaced the empty string once put one table between every character
//! of docs/accuracy.md: 1.66 million lines, which nothing else noticed.)

use std::collections::HashMap;
use std::path::{Path, PathBuf};

fn markdown_files() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = vec![root.join("README.md")];
    for entry in std::fs::read_dir(root.join("docs")).expect("docs/") {
        let path = entry.expect("a docs/ entry").path();
        if path.extension().is_some_and(|e| e == "md") {
            files.push(path);
        }
    }
    files.sort();
    files
}

/// Largest Markdown file: the largest today is under 130 KiB.
const MAX_BYTES: u64 = 400 * 1024;
/// Most times one line of prose (30 characters or more, not a table row, not in a code block)
/// may appear in a file.
const MAX_REPEATS: usize = 8;

#[test]
fn markdown_files_are_of_a_readable_size_and_repeat_no_line_many_times() {
    let files = markdown_files();
    assert!(files.len() >= 8, "found {files:?}");
    for file in files {
        let bytes = std::fs::metadata(&file).expect("metadata").len();
        assert!(
            bytes <= MAX_BYTES,
            "{}: {bytes} bytes (more than {MAX_BYTES}): a runaway edit?",
            file.display()
        );
        let text = std::fs::read_to_string(&file).expect("UTF-8 Markdown");
        let mut seen: HashMap<&str, usize> = HashMap::new();
        let mut in_code = false;
        for line in text.lines().map(str::trim) {
            if line.starts_with("```") {
                in_code = !in_code;
            }
            if in_code || line.starts_with('|') || line.len() < 30 {
                continue;
            }
            let n = seen.entry(line).or_default();
            *n += 1;
            assert!(
                *n <= MAX_REPEATS,
                "{}: the line {line:?} appears more than {MAX_REPEATS} times",
                file.display()
            );
        }
    }
}

#[test]
fn every_picture_a_markdown_file_shows_exists() {
    for file in markdown_files() {
        let text = std::fs::read_to_string(&file).expect("UTF-8 Markdown");
        let dir = file.parent().expect("a folder");
        for (i, _) in text.match_indices("](") {
            let rest = &text[i + 2..];
            let Some(end) = rest.find(')') else { continue };
            let target = rest[..end].split_whitespace().next().unwrap_or("");
            let is_picture = [".png", ".svg", ".jpg", ".gif"]
                .iter()
                .any(|ext| target.ends_with(ext));
            if !is_picture || target.contains("://") {
                continue;
            }
            assert!(
                dir.join(target).exists(),
                "{}: the picture {target} does not exist",
                file.display()
            );
        }
    }
}
