//! glTF 2.0 (.gltf / .glb) → [`Scene`](super::Scene). Owned by the scene-loader work.
use super::Scene;
use std::path::Path;

/// Load a scene from a `.gltf` or `.glb` file.
pub fn load(path: &Path) -> anyhow::Result<Scene> {
    anyhow::bail!("{}: glTF loading is not implemented yet", path.display())
}
