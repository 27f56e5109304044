//! Scenes embedded in the binary, so `ispm render` works from any directory.
//!
//! The `.glb` files are written by `cargo run --example make-scenes` from
//! [`authoring`](super::authoring); a test keeps the committed files equal to its output.

use super::load::{self, LoadOptions};
use super::Scene;
use anyhow::Result;
use std::path::Path;

/// Names of the bundled scenes, the first being the default.
pub const BUNDLED: &[&str] = &[
    "cornell-box",
    "caustic-ring",
    "glass-sphere",
    "diffuse-box",
    "thin-walls",
    "facing-mirrors",
    "glass-cube",
];

/// The scene used when the command line names none.
pub const DEFAULT_SCENE: &str = "cornell-box";

/// The `.glb` bytes of a bundled scene.
pub fn bundled(name: &str) -> Option<&'static [u8]> {
    match name {
        "cornell-box" => Some(include_bytes!("../../assets/cornell-box.glb")),
        "caustic-ring" => Some(include_bytes!("../../assets/caustic-ring.glb")),
        "glass-sphere" => Some(include_bytes!("../../assets/glass-sphere.glb")),
        "diffuse-box" => Some(include_bytes!("../../assets/diffuse-box.glb")),
        "thin-walls" => Some(include_bytes!("../../assets/thin-walls.glb")),
        "facing-mirrors" => Some(include_bytes!("../../assets/facing-mirrors.glb")),
        "glass-cube" => Some(include_bytes!("../../assets/glass-cube.glb")),
        _ => None,
    }
}

/// The scene a command-line `SCENE` argument names: `None` ⇒ the Cornell box; a bundled name
/// ⇒ that scene; anything else ⇒ a path to a `.gltf`/`.glb` file.
pub fn resolve(arg: Option<&str>) -> Result<Scene> {
    resolve_with(arg, &LoadOptions::default())
}

/// [`resolve`] with [`LoadOptions`].
pub fn resolve_with(arg: Option<&str>, options: &LoadOptions) -> Result<Scene> {
    let name = arg.unwrap_or(DEFAULT_SCENE);
    match bundled(name) {
        Some(bytes) => load::load_from_slice_with(bytes, name, None, options),
        None => load::load_with(Path::new(name), options),
    }
}
