// Constants shared by the CPU and the shaders: the single source of truth.
//
// This file is `include!`d by `src/layout/mod.rs` (as `ispm::layout::shared_constants`) and by `build.rs`,
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

// Path density (DESIGN.md §2.2, paper §5): ρp is multiplied at each bounce by the chosen lobe's
// mean reflectance divided by these (Lambertian ρL/1000, glossy ρS/10; mirror and refraction
// divide by 1).
pub const PATH_DENSITY_LAMBERTIAN_DIVISOR: f32 = 1000.0;
pub const PATH_DENSITY_GLOSSY_DIVISOR: f32 = 10.0;
// Packed directions store ω·(ρp + 1); ρp is clamped to [0, this] so that ‖v‖² stays finite in f32.
pub const PATH_DENSITY_MAX: f32 = 1.0e15;
// Stored photons' normals are packed as n̂·r (r: the kNN kernel radius in metres,
// `photon::density`); r is clamped to [min, max] so that it stays > 0 (the normal's direction
// survives) and ‖v‖² stays a normal, finite f32 (10⁻¹⁸ … 10¹⁸).
pub const PACKED_RADIUS_MIN: f32 = 1.0e-9;
pub const PACKED_RADIUS_MAX: f32 = 1.0e9;
// Squared length below which a normal or direction counts as degenerate (the BSDF returns zero).
pub const BSDF_MIN_LENGTH_SQUARED: f32 = 1.0e-12;
// Cosine (to the shading normal) below which wo or a reflected wi counts as tangent: the BSDF
// returns zero there, which bounds the glossy f (≤ ~1e19) and costs no measurable energy.
pub const BSDF_MIN_COS: f32 = 1.0e-7;
// Largest finite glossy exponent σ (a lobe about 0.1° wide); larger finite values are clamped to
// it so that f stays finite in f32 even at grazing angles. σ = ∞ is the perfect mirror.
pub const GLOSSY_EXPONENT_MAX: f32 = 1.0e6;

// Specialisation-constant ids of the über-BSDF's optional lobes (`layout(constant_id = …)` in
// bsdf.glsl; `photon::bsdf::BsdfVariant` gives their values). A lobe whose constant is false is
// compiled out: its reflectance is zero and its sampling and evaluation code is dead.
// Finite-exponent glossy lobe.
pub const SPEC_ID_GLOSSY_LOBE: u32 = 0;
// Delta lobes: perfect mirror and refraction.
pub const SPEC_ID_DELTA_LOBES: u32 = 1;
// The direct pass writes the Lambertian lobe's BRDF c_L/π for the upsample (`passes/direct.rs`),
// beside the über-BSDF's two.
pub const SPEC_ID_WRITE_LAMBERT: u32 = 2;
// The translucent pass's pipeline for convex objects: rays leaving the object through the face
// they start on skip its traversal (`passes/translucent.rs`). The other pipeline, for every
// other delta object, has the test compiled out.
pub const SPEC_ID_CONVEX_SHORTCUT: u32 = 3;
// The photon estimate runs on the 1/N grid (`--subsample N > 1`): photon_tiles.comp and
// support.comp's `SUBSAMPLED`.
pub const SPEC_ID_SUBSAMPLED: u32 = 4;
// upsample.comp's `BLOCK` (an int): the side of the block of pixels an invocation shades.
pub const SPEC_ID_UPSAMPLE_BLOCK: u32 = 5;
// Each id its own, checked at compile time (a new id goes in this list too): a pipeline gives
// every stage all its entries, so a shader that declared two constants with one id would read
// one value for both.
const _: () = assert!(distinct(&[
    SPEC_ID_GLOSSY_LOBE,
    SPEC_ID_DELTA_LOBES,
    SPEC_ID_WRITE_LAMBERT,
    SPEC_ID_CONVEX_SHORTCUT,
    SPEC_ID_SUBSAMPLED,
    SPEC_ID_UPSAMPLE_BLOCK,
]));

/// True when no two of `ids` are equal.
const fn distinct(ids: &[u32]) -> bool {
    let mut i = 0;
    while i < ids.len() {
        let mut j = i + 1;
        while j < ids.len() {
            if ids[i] == ids[j] {
                return false;
            }
            j += 1;
        }
        i += 1;
    }
    true
}

// Kinds of light (`GpuLight.shadow.x`, `BounceView.kind.x`; `plan/lighting.rs`).
pub const LIGHT_POINT: u32 = 0;
// KHR_lights_punctual spot: falloff between the inner and outer cone.
pub const LIGHT_SPOT: u32 = 1;
pub const LIGHT_DIRECTIONAL: u32 = 2;
// A point sampled on an emissive surface (`scene::emitters`): falloff max(0, cos θ) about the
// surface's normal, nothing behind it.
pub const LIGHT_AREA_SAMPLE: u32 = 3;

// Roles of a light view in the bounce map (`BounceView.kind.y`; caustic views, src/plan/bounce_plan.rs).
// Every texel carries its photon.
pub const BOUNCE_VIEW_WHOLE: u32 = 0;
// A main view with a caustic view: a texel whose first hit is a delta material carries nothing;
// another carries the part of its power that its texels in the caustic view do not take.
pub const BOUNCE_VIEW_PARENT: u32 = 1;
// A caustic view: a texel carries 1/k² of its parent texel's power if its own first hit or its
// parent's is a delta material.
pub const BOUNCE_VIEW_CAUSTIC: u32 = 2;

// Depth of the near and far planes in the light views the photons start from (light G-buffers,
// bounce map, `BouncePlan`): reversed Z, so that the near plane can lie a millionth of the
// scene's size from the light (a light touching a surface still sees it, `plan/lighting.rs`) and a
// D32F depth buffer keeps its relative precision to the far plane.
pub const LIGHT_VIEW_NEAR_Z: f32 = 1.0;
pub const LIGHT_VIEW_FAR_Z: f32 = 0.0;

// Where inside its texel a light-view photon passes (`bounce_plan::texel_jitter`, `bounce_map.comp`):
// a per-texel random offset (two hashes of the texel's key with these salts) rotated by point
// `sample` of the R2 sequence, in 32-bit fixed point: `JITTER_R2_X/Y` are 2^32/g and 2^32/g²,
// g = 1.3247179572 the plastic number (Roberts 2018), so a texel's offsets over the frames of
// an accumulation are a low-discrepancy sequence and no two texels share one (no lattice).
pub const JITTER_STREAM_X: u32 = 0x7e1a_91c3;
pub const JITTER_STREAM_Y: u32 = 0x2b5d_06f7;
pub const JITTER_R2_X: u32 = 3242174890;
pub const JITTER_R2_Y: u32 = 2447445414;

// Whether a light-view texel sends its photon this frame (`bounce_plan::texel_kept`, `bounce_map.comp`):
// a per-texel random number (a hash of the texel's key with this salt) rotated by `sample` times
// 2^32/φ (the golden ratio: the R1 sequence), in 32-bit fixed point, below the view's keep
// probability. Over the frames of an accumulation each texel is kept in that fraction of them,
// evenly spread.
pub const KEEP_STREAM: u32 = 0x4b33_7e9d;
pub const KEEP_R1: u32 = 2654435769;

// A photon is a caustic photon when its path density ρp exceeds this (`photon::density`): every
// bounce on its path was a mirror, refraction or glossy one.
pub const CAUSTIC_PATH_DENSITY: f32 = 1.0e-2;
// Which photons one density estimate draws (`photon::kernel::Share`): every one, the fine ones
// (caustic photons with kernels narrower than the split; at `--subsample N > 1` estimated at
// full resolution, `render/photon_frame/estimate.rs`) or the others.
pub const SHARE_ALL: u32 = 0;
pub const SHARE_FINE: u32 = 1;
pub const SHARE_COARSE: u32 = 2;
// The kernel-support normalisation of the global photons' estimate (`passes/support.rs`): the
// smallest on-surface fraction of a kernel it divides by (a straight convex edge's), and the
// cosine between a global photon's normal and the shaded surface's below which the photon does
// not reach the surface (a photon on the other wall of a crease).
pub const SUPPORT_FRACTION_MIN: f32 = 0.5;
pub const SUPPORT_NORMAL_COS: f32 = 0.9;
// The joint bilateral weights' normal term max(0, n·n')^(2^k) (`passes/denoise.rs`,
// `passes/upsample.rs`): a power of two, raised by k squarings in a loop of constant count, which
// llvmpipe unrolls (pow, or a loop whose count is a push constant, costs more there).
pub const DENOISE_NORMAL_POWER_LOG2: u32 = 5;
pub const UPSAMPLE_NORMAL_POWER_LOG2: u32 = 3;
// The upsample's block: an invocation shades up to this many pixels square that share their
// four low-resolution samples (`passes/upsample.rs`).
pub const UPSAMPLE_BLOCK: u32 = 4;

// Photon-volume billboards (`passes/photon_volumes.rs`, `photon_volumes.vert`): the eye counts
// as inside a kernel's bounding sphere up to this multiple of its radius (the billboard's half
// size grows without bound as the distance nears the radius), and the billboard is this much
// wider than the tangent cone's section, against rounding.
pub const BILLBOARD_INSIDE: f32 = 1.001;
pub const BILLBOARD_MARGIN: f32 = 1.001;

// Tiled density estimation (`passes/photon_tiles.rs`, `photon_tiles.comp`): pixels per side of
// a screen tile, one workgroup's (8: one row is one of lavapipe's 8-lane SIMD vectors).
pub const PHOTON_TILE: u32 = 8;
// The most entries of one tile's list one dispatch of `photon_tiles.comp` gathers: lavapipe
// ends an invocation's loops after 65535 iterations in all (the tile loop takes about
// 1 + 1/subgroup size of them per entry), so longer lists take several dispatches.
pub const TILE_JOB: u32 = 16384;
