//! One explicit GPU pass per file. Each pass is a struct with `new` (pipelines and descriptor
//! sets) and `record` (its commands, inside a scope named after the pass, which is both its
//! debug label and its timestamp scope). Inputs are taken by `&`, outputs by `&mut`.
//!
//! | pass | queue | reads | writes |
//! |---|---|---|---|
//! | [`shadow_map`] | graphics | scene geometry | shadow atlas (one layer per light view) |
//! | [`light_gbuffer`] | graphics | scene geometry, materials | light G-buffer (a layer per view) |
//! | [`bounce_map`] | graphics (compute) | light G-buffer, materials | bounce map (first bounces) |
//! | [`eye_gbuffer`] | graphics | scene geometry, materials, textures | eye G-buffer |
//! | [`direct`] | graphics (compute) | G-buffer, lights, shadow atlas | HDR radiance |
//! | [`photon_volumes`] | graphics | photon map, eye G-buffer | HDR indirect radiance |
//! | [`upsample`] | graphics (compute) | 1/N indirect, eye G-buffer, materials | HDR indirect |
//! | [`composite`] | graphics (compute) | indirect | HDR radiance (+= indirect) |
//! | [`environment`] | graphics | scene geometry (opaque), lights, shadow atlas | environment cube map (cached) |
//! | [`translucent`] | graphics | delta instances, lights, shadow atlas, cube map, eye depth | HDR radiance (over) |
//! | [`tonemap`] | graphics (compute) | HDR radiance | 8-bit display image |

pub mod bounce_map;
pub mod composite;
pub mod direct;
pub mod environment;
pub mod eye_gbuffer;
pub mod light_gbuffer;
pub mod photon_volumes;
pub mod shadow_map;
pub mod tonemap;
pub mod translucent;
pub mod upsample;

/// The vertex layout every raster pass reads (see [`crate::layout::Vertex`]).
pub(crate) fn vertex_attributes() -> [crate::gpu::VertexAttribute; 3] {
    use crate::gpu::{vk, VertexAttribute};
    [
        VertexAttribute {
            location: 0,
            format: vk::Format::R32G32B32_SFLOAT,
            offset: 0,
        },
        VertexAttribute {
            location: 1,
            format: vk::Format::R32G32B32_SFLOAT,
            offset: 12,
        },
        VertexAttribute {
            location: 2,
            format: vk::Format::R32G32_SFLOAT,
            offset: 24,
        },
    ]
}

/// Workgroup size (x and y) of the per-pixel compute passes; matches `local_size` in GLSL.
pub(crate) const TILE: u32 = 8;

/// Workgroups needed to cover `n` pixels.
pub(crate) fn groups(n: u32) -> u32 {
    n.div_ceil(TILE)
}
