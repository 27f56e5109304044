// Constants shared by the CPU and the shaders: the single source of truth.
//
// This file is `include!`d by `src/lib.rs` (as `ispm::shared_constants`) and by `build.rs`,
// which turns every `pub const NAME: f32|u32|i32 = value;` line into a GLSL `const` in the
// generated header `shared_constants.glsl` that every shader can `#include`. Keep to that
// form: one constant per line, literal values or simple expressions GLSL also accepts, and
// only `//` comments (this file is included as items, so inner doc comments are not allowed).

/// π, as the shaders spell it.
pub const PI: f32 = 3.141_592_7;
