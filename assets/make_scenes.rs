//! Writes the bundled scenes (`assets/*.glb`) from `ispm::scene::authoring`.
//!
//! Run `cargo run --example make-scenes` after changing the authoring code; the test
//! `committed_glbs_equal_generator_output` fails until the files are regenerated.

use anyhow::Context;
use std::path::Path;

fn main() -> anyhow::Result<()> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
    for (name, bytes) in ispm::scene::authoring::all() {
        let path = dir.join(format!("{name}.glb"));
        std::fs::write(&path, &bytes)
            .with_context(|| format!("{}: cannot write", path.display()))?;
        println!("{}: {} bytes", path.display(), bytes.len());
    }
    Ok(())
}
