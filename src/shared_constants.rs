// Constants shared by the CPU and the shaders: the single source of truth.
//
// This file is `include!`d by `src/lib.rs` (as `ispm::shared_constants`) and by `build.rs`,
// which turns every `pub const NAME: f32|u32|i32 = value;` line into a GLSL `const` in the
// generated header `shared_constants.glsl` that every shader can `#include`. Keep to that
// form: one constant per line, literal values or simple expressions GLSL also accepts, and
// only `//` comments (this file is included as items, so inner doc comments are not allowed).

/// π, as the shaders spell it.
pub const PI: f32 = core::f32::consts::PI;

// Tonemapping operators (`--tonemap`), as ids the tonemap shader switches on.
pub const TONEMAP_LINEAR: u32 = 0;
pub const TONEMAP_ACES: u32 = 1;
pub const TONEMAP_PBR_NEUTRAL: u32 = 2;
