//! The CPU photon tracer (DESIGN.md §2 step 4, paper §5): photons leaving the first bounce are
//! traced on through the scene with Russian roulette, and stored just before each indirect
//! bounce.
//!
//! # Two inputs, one continuation
//! - **From the lights** (the references): [`trace_from_lights`] traces each
//!   [`EmittedPhoton`] to its first hit and bounces it there ([`first_bounce`], the CPU
//!   equivalent of one bounce-map texel), then continues with [`trace_photons`].
//! - **From the GPU bounce map**: [`PhotonState::from_bounce_map`] turns a read-back texel (its
//!   position recovered from the light G-buffer depth by the caller, with an error bound) into
//!   the same state.
//!
//! # What is stored, and where
//! A photon is stored at the k-th surface it hits only when k ≥ 2 (it has bounced at least
//! once: hit 1 is direct light, which the renderer computes with shadow maps / NEE) **and** the
//! surface has a non-delta lobe (Lambertian, or glossy with a finite exponent): the surface
//! seen by the eye through the photon's kernel must have a finite BSDF, and a pure mirror or
//! glass surface never is the last surface before the eye (the eye path follows delta
//! bounces). A photon reaching a diffuse floor through glass (L S D, a caustic) is stored; a
//! photon at the glass itself is not. The stored record is the *incident* power, the incident
//! direction (towards where it came from) packed with the path density ρp of the path so far,
//! the hit position and the geometric normal turned to the incident side. Storing happens
//! before the bounce, and independently of whether the photon then survives.
//!
//! Glass and mirrors with a finite layer (`cornell-box`'s glass sphere has a Lambertian 0.02)
//! are the one place the two consumers differ ([`StoreOn`]): the CPU references' eye paths
//! gather there, but ISPM draws such surfaces in the forward translucent pass, never in the eye
//! G-buffer, so its photon map ([`StoreOn::EyeGBuffer`]) leaves them out. On `cornell-box` at
//! 100k photons they were 67 % of the stored photons (262k of 392k, most of them from the
//! caught paths of "Trapped paths"), each drawn as a photon volume that could light no pixel.
//!
//! # Bounces
//! Russian roulette ends a photon's path: at every bounce it survives with the probability of
//! the BSDF's albedo, so in a closed room of albedo a it bounces 1/(1 − a) times on average and
//! no power is lost to a bounce count. The first bounce (the GPU's bounce map) takes the albedo
//! as the mean of the channels, as the paper does; every later one weights the channels by the
//! photon's own power (`Bsdf::sample_russian_roulette_for`), so a surviving photon keeps the
//! sum of its channels (in expectation after a glossy lobe). With the mean, a photon bouncing
//! between red walls gained ~2.5× in red per bounce, and on `cornell-box` (40k photons) one
//! carried 130 times a typical photon's power into a 2-pixel red blotch on the white back wall.
//! `max_bounces` (default [`MAX_BOUNCES`], a safety net for rooms of albedo 1) caps the number
//! of scattering events: stored photons have 1…`max_bounces` bounces; `--bounces N` lowers it
//! when asked. `attrition[k]` counts the photons alive after bounce k
//! (`attrition[0]`: photons emitted with non-zero power; paper Fig. 10).
//! η is tracked as the product of the relative indices crossed by refraction.
//!
//! # Trapped paths
//! Total internal reflection has albedo 1, so roulette never ends a photon caught in it. In an
//! exact sphere no photon from outside can be caught (each chord meets the surface at the angle
//! it entered at), but a tessellated one with interpolated shading normals catches some: on
//! `cornell-box` (100k photons) 670 photons circled inside the glass sphere to the 256-bounce
//! cap, 38 % of the rays traced and, each storing a photon on the glass's Lambertian layer at
//! every hit, 44 % of the photons stored. A path is therefore ended after [`MAX_DELTA_CHAIN`]
//! delta scatterings in a row *inside a dielectric* (η ≠ 1 after the scattering): there a
//! chain is the photon bouncing inside glass, which an exact object lets go within a few
//! bounces. What that drops is the light of paths that would have left such a chain after more
//! than 32 steps: of the photons alive after 45 bounces on `cornell-box`, 1 in 671 left before
//! the 256 cap. Chains in air are not counted: between facing mirrors (`facing-mirrors`,
//! albedo 0.95) roulette ends them, and 0.95³² = 19 % of such a chain's photons are still going
//! after 32 reflections, light a cap would have dropped. The image is unchanged (`cornell-box`,
//! 640×480, 3 frames: relMSE 0.0000 against the uncapped trace; `tests/physics_photons.rs`
//! checks that nothing is alive at 4 × the limit). The cap applies to the CPU references too:
//! their caught photons stored on the glass's inside, which their eye paths, arriving from
//! outside, cannot gather either.
//!
//! # Variants
//! [`TraceSettings::variant`] compiles optional lobes out of the trace as the shaders'
//! specialisation constants do (`docs/effects.md`): the path loop is monomorphised per
//! [`BsdfVariant`] (`Bsdf::sample_russian_roulette_in`), so without the delta lobes (no mirror
//! or refracting material in the scene) it holds no mirror, refraction or η-tracking code: no
//! caustic paths. A compiled-out lobe has reflectance 0, so for materials without it the photon
//! map is the same bit for bit. [`first_bounce`] (the CPU references) always has every lobe.
//!
//! # Determinism
//! Each path draws from `Rng::new(hash2(path_key, seed))` (frame-coherent). The CPU
//! references' paths are keyed by where they start (`hash_vec3(origin)`: the same start gives
//! the same path); the GPU bounce map's by the texel they come from
//! ([`crate::plan::bounce_plan::BouncePlan::photon_starts`]), so that a slowly moving light keeps each
//! path's random numbers and its photons move with it instead of being drawn anew (the
//! temporal stability case, docs/stability.md). Work is split into chunks traced in parallel by
//! rayon (about eight per thread, 32 to 256 paths each); per-chunk buffers are concatenated in
//! chunk order, so the photons and the attrition depend neither on the number of threads nor on
//! the chunks (`stored_power`, a diagnostic sum of f32 powers, is summed per chunk and may
//! differ in its last bits). Each chunk is a `trace_chunk` span on its worker's track
//! ([`crate::timing`]), in the frame of the thread that called [`trace_photons`].

use super::bsdf::{Bsdf, BsdfVariant, Lobe};
use super::bvh::SceneBvh;
use super::emit::EmittedPhoton;
use super::ray::{Hit, Ray, TriangleKey};
use super::rng::{hash2, hash_vec3, Rng};
use super::types::{pack_direction, unpack_direction, BounceMapPhoton, Photon};
use crate::scene::{Material, Scene, Texture};
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// Paths per parallel work item, at most.
const CHUNK: usize = 256;

/// Paths per parallel work item for `paths` paths on the current rayon pool: about eight
/// items per thread, so that on many threads the last items do not leave most of them idle
/// (10 000 photons on 16 threads were 40 items of 256, ~2.5 per thread), between 32 and
/// [`CHUNK`]. The default render on an H100 host (16 threads), three runs of each binary
/// alternately: the trace's span 4.53 → 4.26 ms (medians), the frame within noise. A path depends on its start only, so the photons are the same for any size
/// (module docs).
fn chunk_size(paths: usize) -> usize {
    (paths / (rayon::current_num_threads() * 8)).clamp(32, CHUNK)
}
/// The default bounce cap of photon and path tracing: only a safety net, Russian roulette ends
/// the paths long before it (a room of albedo 0.95 keeps 0.95²⁵⁷ ≈ 2·10⁻⁶ of the light after
/// it). `--bounces N` sets a lower cap.
pub const MAX_BOUNCES: u32 = 256;
/// The most delta scatterings (mirror reflections, refractions, total internal reflection) a
/// photon takes in a row inside a dielectric: a path past it is ended ("Trapped paths").
pub const MAX_DELTA_CHAIN: u32 = 32;
/// Stream of the first bounce in a photon's RNG seed (emission uses the seed itself).
const FIRST_BOUNCE_STREAM: u32 = 0x6f1b_0b01;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraceSettings {
    /// Most scattering events a photon may take (≥ 1).
    pub max_bounces: u32,
    /// The renderer's `--seed`.
    pub seed: u32,
    /// The über-BSDF lobes compiled into the trace (module docs, "Variants"): the effects
    /// plan's, as for the shaders.
    pub variant: BsdfVariant,
    /// The surfaces that keep the photons reaching them (module docs, "What is stored, and
    /// where").
    pub store_on: StoreOn,
}

impl Default for TraceSettings {
    fn default() -> Self {
        Self {
            max_bounces: MAX_BOUNCES,
            seed: 0,
            variant: BsdfVariant::ALL,
            store_on: StoreOn::FiniteLobes,
        }
    }
}

/// The surfaces a photon is stored on (after its first bounce).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StoreOn {
    /// Every surface with a finite lobe, glass and mirrors with a diffuse or glossy layer
    /// included: the CPU references and `photon-gather`, whose eye paths gather there too.
    FiniteLobes,
    /// Only the surfaces the eye G-buffer holds, those with a finite lobe and no delta lobe
    /// ([`Material::has_delta_lobe`]): ISPM's photon map. The forward translucent pass draws
    /// the others from cube maps (the photons' light reaches them gathered at the opaque
    /// surfaces they reflect, `photon_frame/environment.rs`), so a photon stored on them would
    /// be drawn for nothing.
    EyeGBuffer,
}

/// A photon in flight that has bounced `bounces` times and now leaves `origin`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhotonState {
    /// Start of the next ray (already offset off the surface it leaves).
    pub origin: Vec3,
    /// Unit direction of travel.
    pub direction: Vec3,
    pub power: Vec3,
    /// Path density so far (1 at the light).
    pub rho_p: f32,
    /// Index of refraction of the medium it travels in.
    pub eta: f32,
    pub bounces: u32,
    /// What the path's random numbers are drawn from, with the global seed: a hash of the
    /// start point for the CPU references, of the bounce-map texel for the GPU's photons
    /// (module docs, "Determinism").
    pub path_key: u32,
    /// The triangle the photon leaves, which its next ray skips ([`TriangleKey`]).
    pub leaves: TriangleKey,
}

impl PhotonState {
    /// The state of a GPU bounce-map photon whose hit point (recovered from the light
    /// G-buffer's depth) is `position`, within `error` metres. `None` for absorbed texels
    /// (zero power or direction). The read-back texel has no normal, so the origin is pushed
    /// along the direction by the error bound ([`BouncePlan::photon_starts`] computes it from
    /// the scene's scale and the position's magnitude).
    ///
    /// [`BouncePlan::photon_starts`]: crate::plan::bounce_plan::BouncePlan::photon_starts
    pub fn from_bounce_map(
        p: &BounceMapPhoton,
        position: Vec3,
        error: f32,
        path_key: u32,
    ) -> Option<Self> {
        let (direction, rho_p) = unpack_direction(p.direction);
        if direction == Vec3::ZERO || p.power.max_element() <= 0.0 || !p.power.is_finite() {
            return None;
        }
        Some(Self {
            origin: position + direction * error,
            direction,
            power: p.power,
            rho_p,
            eta: if p.eta > 0.0 { p.eta } else { 1.0 },
            bounces: 1,
            path_key,
            leaves: TriangleKey::NONE,
        })
    }

    /// The ray the photon travels along next.
    pub fn ray(&self) -> Ray {
        Ray::new(self.origin, self.direction).leaving(self.leaves)
    }

    /// The bounce-map record of this state at light G-buffer depth `depth`.
    pub fn to_bounce_map(&self, depth: f32) -> BounceMapPhoton {
        BounceMapPhoton {
            power: self.power,
            direction: pack_direction(self.direction, self.rho_p),
            eta: self.eta,
            depth,
        }
    }
}

/// The traced photons and their statistics.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PhotonMap {
    pub photons: Vec<Photon>,
    /// `attrition[k]`: photons alive after bounce k (length `max_bounces + 1`).
    pub attrition: Vec<u64>,
    /// `stored_power[k]`: total power of the photons stored after k bounces (index 0 unused).
    pub stored_power: Vec<Vec3>,
    /// Number of photons emitted (trace from lights) or started (bounce map).
    pub emitted: u64,
}

/// Sampled Lambertian reflectance of `material` at `uv` (nearest texel, repeat, sRGB decoded).
pub fn lambertian_at(scene: &Scene, material: &Material, uv: Vec2) -> Option<Vec3> {
    let tex = lambertian_texture(scene, material)?;
    let x = ((uv.x - uv.x.floor()) * tex.width as f32) as u32 % tex.width;
    let y = ((uv.y - uv.y.floor()) * tex.height as f32) as u32 % tex.height;
    let i = ((y * tex.width + x) * 4) as usize;
    let decode = |c: u8| {
        let c = c as f32 / 255.0;
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    };
    Some(
        material.lambertian
            * Vec3::new(
                decode(tex.rgba8[i]),
                decode(tex.rgba8[i + 1]),
                decode(tex.rgba8[i + 2]),
            ),
    )
}

/// The texture of `material`'s Lambertian reflectance, when it has one that can be sampled.
fn lambertian_texture<'a>(scene: &'a Scene, material: &Material) -> Option<&'a Texture> {
    let tex = scene.textures.get(material.lambertian_texture?)?;
    let texels = tex.width as usize * tex.height as usize;
    (texels > 0 && tex.rgba8.len() >= texels * 4).then_some(tex)
}

/// The BSDF at a hit (texture applied).
pub fn bsdf_at(scene: &Scene, hit: &Hit) -> Bsdf {
    let material = &scene.materials[hit.material];
    Bsdf::new(material, lambertian_at(scene, material, hit.uv))
}

/// The BSDF of each material without a texture (or with one that cannot be sampled), built
/// once per trace: a hit on one would build the same BSDF again in [`bsdf_at`], whose only
/// per-hit input is the texel.
struct MaterialBsdfs(Vec<Option<Bsdf>>);

impl MaterialBsdfs {
    fn new(scene: &Scene) -> Self {
        Self(
            scene
                .materials
                .iter()
                .map(|m| {
                    lambertian_texture(scene, m)
                        .is_none()
                        .then(|| Bsdf::new(m, None))
                })
                .collect(),
        )
    }

    /// [`bsdf_at`] of `hit`, the same bits.
    #[inline(always)]
    fn at(&self, scene: &Scene, hit: &Hit) -> Bsdf {
        match self.0.get(hit.material) {
            Some(Some(bsdf)) => *bsdf,
            _ => bsdf_at(scene, hit),
        }
    }
}

/// The radiance the surface at `hit` emits back along the ray: emitters emit from their front
/// side only, unless double-sided (`scene::emitters`; the GPU's twin is `material_emission`
/// in `glsl/common/material.glsl`).
pub fn emitted(scene: &Scene, hit: &Hit) -> Vec3 {
    let material = &scene.materials[hit.material];
    if hit.front_face || material.double_sided {
        material.emission
    } else {
        Vec3::ZERO
    }
}

/// True when `power` is finite and positive in some channel.
pub fn carries_power(power: Vec3) -> bool {
    power.is_finite() && power.max_element() > 0.0
}

/// True when the BSDF has a finite (non-delta) part the eye can see photons through.
pub fn has_finite_lobe(bsdf: &Bsdf) -> bool {
    bsdf.lambertian.max_element() > 0.0
        || (bsdf.exponent.is_finite() && (bsdf.glossy.max_element() > 0.0 || bsdf.fresnel))
}

/// Scatters a photon arriving at `hit` along `dir` with the BSDF variant `GLOSSY`, `DELTA`:
/// its next state and the lobe it took; `None` when absorbed.
#[inline(always)]
fn scatter<const GLOSSY: bool, const DELTA: bool>(
    bsdf: &Bsdf,
    hit: &Hit,
    dir: Vec3,
    state: &PhotonState,
    rng: &mut Rng,
) -> Option<(PhotonState, Lobe)> {
    // The first bounce as the GPU's bounce map plays it (the mean albedo); every later one by the
    // photon's own colour, which keeps its power from growing ("Bounces").
    let s = if state.bounces == 0 {
        bsdf.sample_russian_roulette_in::<GLOSSY, DELTA>(
            -dir,
            hit.shading_normal,
            hit.geometric_normal,
            rng.next_3(),
        )?
    } else {
        bsdf.sample_russian_roulette_for::<GLOSSY, DELTA>(
            state.power,
            -dir,
            hit.shading_normal,
            hit.geometric_normal,
            rng.next_3(),
        )?
    };
    let power = state.power * s.weight;
    if !carries_power(power) {
        return None;
    }
    let eta = if DELTA && s.lobe == Lobe::Refraction {
        state.eta * s.eta
    } else {
        state.eta
    };
    let ray = hit.spawn_ray(s.wi);
    let next = PhotonState {
        origin: ray.origin,
        direction: s.wi,
        power,
        rho_p: state.rho_p * s.path_density_factor,
        eta,
        bounces: state.bounces + 1,
        path_key: state.path_key,
        leaves: ray.leaves,
    };
    Some((next, s.lobe))
}

/// The CPU bounce map: traces an emitted photon to its first hit and bounces it there (no
/// photon is stored: hit 1 is direct light). `None` when it misses or is absorbed.
pub fn first_bounce(scene: &Scene, bvh: &SceneBvh, photon: &EmittedPhoton) -> Option<PhotonState> {
    first_bounce_with(bvh, photon, |hit| bsdf_at(scene, hit))
}

/// [`first_bounce`] with `bsdf` giving the BSDF at a hit ([`first_bounces`]: from the
/// materials' table).
#[inline(always)]
fn first_bounce_with(
    bvh: &SceneBvh,
    photon: &EmittedPhoton,
    bsdf: impl Fn(&Hit) -> Bsdf,
) -> Option<PhotonState> {
    if !carries_power(photon.power) {
        return None;
    }
    let hit = bvh.intersect(&Ray::new(photon.origin, photon.direction))?;
    let start = PhotonState {
        origin: photon.origin,
        direction: photon.direction,
        power: photon.power,
        rho_p: 1.0,
        eta: 1.0,
        bounces: 0,
        path_key: 0,
        leaves: TriangleKey::NONE,
    };
    let mut rng = Rng::new(hash2(photon.seed, FIRST_BOUNCE_STREAM));
    let (bounced, _) =
        scatter::<true, true>(&bsdf(&hit), &hit, photon.direction, &start, &mut rng)?;
    Some(PhotonState {
        path_key: hash_vec3(bounced.origin),
        ..bounced
    })
}

#[derive(Default)]
struct Chunk {
    photons: Vec<Photon>,
    attrition: Vec<u64>,
    stored_power: Vec<Vec3>,
}

impl Chunk {
    /// An empty chunk for `paths` paths, with room for two photons a path (most rooms store
    /// one to three; a vector that grows copies what it holds).
    fn new(max_bounces: u32, paths: usize) -> Self {
        let n = max_bounces as usize + 1;
        Self {
            photons: Vec::with_capacity(2 * paths),
            attrition: vec![0; n],
            stored_power: vec![Vec3::ZERO; n],
        }
    }
}

/// One photon's path from `start`, in the BSDF variant `GLOSSY`, `DELTA`.
fn trace_path<const GLOSSY: bool, const DELTA: bool>(
    scene: &Scene,
    bvh: &SceneBvh,
    bsdfs: &MaterialBsdfs,
    start: &PhotonState,
    settings: &TraceSettings,
    out: &mut Chunk,
) {
    let max = settings.max_bounces as usize;
    if start.bounces as usize > max || !carries_power(start.power) {
        return;
    }
    out.attrition[start.bounces as usize] += 1;
    let mut rng = Rng::new(hash2(start.path_key, settings.seed));
    let mut state = *start;
    // Delta scatterings in a row (a start's own first bounce is not known: 0).
    let mut delta_chain = 0;
    loop {
        let Some(hit) = bvh.intersect(&state.ray()) else {
            return;
        };
        let bsdf = bsdfs.at(scene, &hit);
        let k = state.bounces as usize;
        let stored_here = match settings.store_on {
            StoreOn::FiniteLobes => true,
            StoreOn::EyeGBuffer => !scene.materials[hit.material].has_delta_lobe(),
        };
        if k >= 1 && stored_here && has_finite_lobe(&bsdf) {
            let wi = -state.direction;
            let n = if hit.geometric_normal.dot(wi) < 0.0 {
                -hit.geometric_normal
            } else {
                hit.geometric_normal
            };
            out.photons
                .push(Photon::new(state.power, wi, state.rho_p, hit.position, n));
            out.stored_power[k] += state.power;
        }
        if k >= max {
            return;
        }
        match scatter::<GLOSSY, DELTA>(&bsdf, &hit, state.direction, &state, &mut rng) {
            Some((next, lobe)) => {
                // Inside a dielectric (η ≠ 1 after the scattering): only there can a chain be
                // lossless (total internal reflection).
                let inside = (next.eta - 1.0).abs() > 1e-3;
                delta_chain = if lobe.is_delta() && inside {
                    delta_chain + 1
                } else {
                    0
                };
                if delta_chain > MAX_DELTA_CHAIN {
                    return;
                }
                state = next;
                out.attrition[state.bounces as usize] += 1;
            }
            None => return,
        }
    }
}

fn merge(chunks: Vec<Chunk>, max_bounces: u32, emitted: u64) -> PhotonMap {
    let mut total = Chunk::new(max_bounces, 0);
    let count = chunks.iter().map(|c| c.photons.len()).sum();
    total.photons.reserve_exact(count);
    for c in chunks {
        total.photons.extend_from_slice(&c.photons);
        for (a, b) in total.attrition.iter_mut().zip(&c.attrition) {
            *a += b;
        }
        for (a, b) in total.stored_power.iter_mut().zip(&c.stored_power) {
            *a += *b;
        }
    }
    PhotonMap {
        photons: total.photons,
        attrition: total.attrition,
        stored_power: total.stored_power,
        emitted,
    }
}

/// Continues photons that have already bounced (bounce-map photons, or [`first_bounce`]'s),
/// on all of rayon's threads; the result does not depend on the thread count.
pub fn trace_photons(
    scene: &Scene,
    bvh: &SceneBvh,
    starts: &[PhotonState],
    settings: &TraceSettings,
) -> PhotonMap {
    trace_photon_groups(scene, bvh, &[starts], settings)
        .pop()
        .unwrap_or_default()
}

/// [`trace_photons`] of several groups of starts (e.g. one per light) in one parallel pass:
/// one photon map per group, each bit for bit the one [`trace_photons`] makes of that group
/// alone (a path depends on its start only; a group's chunks are its own and are concatenated
/// in order).
pub fn trace_photon_groups(
    scene: &Scene,
    bvh: &SceneBvh,
    groups: &[&[PhotonState]],
    settings: &TraceSettings,
) -> Vec<PhotonMap> {
    let max_bounces = settings.max_bounces.max(1);
    let settings = TraceSettings {
        max_bounces,
        ..*settings
    };
    // The variant's own copy of the path loop: what it compiles out is not in it.
    type PathFn = fn(&Scene, &SceneBvh, &MaterialBsdfs, &PhotonState, &TraceSettings, &mut Chunk);
    let trace_path: PathFn = match (settings.variant.glossy, settings.variant.delta) {
        (true, true) => trace_path::<true, true>,
        (true, false) => trace_path::<true, false>,
        (false, true) => trace_path::<false, true>,
        (false, false) => trace_path::<false, false>,
    };
    let bsdfs = MaterialBsdfs::new(scene);
    let frame = crate::timing::current_frame();
    // Work items: every group's chunks, group after group.
    let chunk = chunk_size(groups.iter().map(|g| g.len()).sum());
    let items: Vec<&[PhotonState]> = groups.iter().flat_map(|g| g.chunks(chunk)).collect();
    let mut chunks = items
        .par_iter()
        .map(|chunk| {
            let _span = crate::timing::span_in("trace_chunk", frame);
            let mut out = Chunk::new(max_bounces, chunk.len());
            for s in *chunk {
                trace_path(scene, bvh, &bsdfs, s, &settings, &mut out);
            }
            out
        })
        .collect::<Vec<Chunk>>()
        .into_iter();
    groups
        .iter()
        .map(|g| {
            let own: Vec<Chunk> = chunks.by_ref().take(g.len().div_ceil(chunk)).collect();
            merge(own, max_bounces, g.len() as u64)
        })
        .collect()
}

/// The CPU bounce map: [`first_bounce`] of every emitted photon, in parallel, in input order,
/// absorbed and missing photons dropped.
pub fn first_bounces(scene: &Scene, bvh: &SceneBvh, emitted: &[EmittedPhoton]) -> Vec<PhotonState> {
    let bsdfs = MaterialBsdfs::new(scene);
    emitted
        .par_chunks(CHUNK)
        .map(|chunk| {
            chunk
                .iter()
                .filter_map(|p| first_bounce_with(bvh, p, |hit| bsdfs.at(scene, hit)))
                .collect::<Vec<_>>()
        })
        .collect::<Vec<_>>()
        .concat()
}

/// The reference path: emitted photons → [`first_bounces`] → [`trace_photons`].
pub fn trace_from_lights(
    scene: &Scene,
    bvh: &SceneBvh,
    emitted: &[EmittedPhoton],
    settings: &TraceSettings,
) -> PhotonMap {
    let starts = first_bounces(scene, bvh, emitted);
    let mut map = trace_photons(scene, bvh, &starts, settings);
    map.attrition[0] = emitted.iter().filter(|p| carries_power(p.power)).count() as u64;
    map.emitted = emitted.len() as u64;
    map
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::emit::emit_photons;
    use crate::reference::scenes::grey_box;

    #[test]
    fn material_bsdfs_give_each_hit_the_bsdf_built_at_it() {
        // The table built once per trace must give every hit what `bsdf_at` builds there:
        // untextured materials from the table, a textured one from its texel, and a material
        // whose texture is missing as if it had none.
        let mut scene = crate::reference::scenes::cornell(1);
        scene.textures.push(crate::scene::Texture {
            name: "checker".into(),
            width: 2,
            height: 2,
            rgba8: vec![
                255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 40, 80, 120, 255,
            ],
        });
        scene.materials[0].lambertian_texture = Some(0);
        scene.materials[1].lambertian_texture = Some(7);
        let bvh = SceneBvh::new(&scene);
        let bsdfs = MaterialBsdfs::new(&scene);
        // The wall with a missing texture is as untextured: in the table.
        assert!(bsdfs.0[0].is_none() && bsdfs.0[1].is_some() && bsdfs.0[2].is_some());
        let mut rng = Rng::new(3);
        let mut seen = std::collections::HashSet::new();
        for _ in 0..4000 {
            let d = crate::photon::sampling::uniform_sphere(rng.next_2());
            let Some(hit) = bvh.intersect(&Ray::new(Vec3::ZERO, d)) else {
                continue;
            };
            assert_eq!(
                format!("{:?}", bsdfs.at(&scene, &hit)),
                format!("{:?}", bsdf_at(&scene, &hit)),
                "the same BSDF, to the bit of every field"
            );
            seen.insert((
                hit.material,
                bsdf_at(&scene, &hit)
                    .lambertian
                    .to_array()
                    .map(f32::to_bits),
            ));
        }
        // Every material was hit, and the textured wall in more than one colour.
        let materials: std::collections::HashSet<_> = seen.iter().map(|(m, _)| *m).collect();
        assert_eq!(materials.len(), scene.materials.len());
        assert!(seen.iter().filter(|(m, _)| *m == 0).count() > 1);
    }

    #[test]
    fn one_bounce_cap_stores_only_once_bounced_photons() {
        let scene = grey_box(0.8, 1.0);
        let bvh = SceneBvh::new(&scene);
        let emitted = emit_photons(&scene, 1000, 2);
        let settings = TraceSettings {
            max_bounces: 1,
            seed: 1,
            ..Default::default()
        };
        let map = trace_from_lights(&scene, &bvh, &emitted, &settings);
        assert_eq!(map.attrition.len(), 2);
        // Closed box: every photon that survived its first bounce is stored once, at hit 2.
        assert_eq!(map.photons.len() as u64, map.attrition[1]);
        assert_eq!(map.stored_power[0], Vec3::ZERO);
    }

    fn trace(scene: &Scene, variant: BsdfVariant) -> PhotonMap {
        let bvh = SceneBvh::new(scene);
        let emitted = emit_photons(scene, 4000, 7);
        let settings = TraceSettings {
            max_bounces: 8,
            seed: 3,
            variant,
            ..Default::default()
        };
        trace_from_lights(scene, &bvh, &emitted, &settings)
    }

    const NO_OPTIONAL_LOBES: BsdfVariant = BsdfVariant {
        glossy: false,
        delta: false,
    };

    #[test]
    fn a_diffuse_scene_traces_the_same_photon_map_with_glossy_and_delta_lobes_compiled_out() {
        let scene = crate::reference::scenes::cornell(1);
        let all = trace(&scene, BsdfVariant::ALL);
        assert!(all.photons.len() > 1000);
        assert!(
            trace(&scene, NO_OPTIONAL_LOBES) == all,
            "the photon map changed"
        );
    }

    #[test]
    fn compiling_out_the_delta_lobes_ends_caustic_paths_at_the_mirror_and_changes_nothing_else() {
        let mut scene = crate::reference::scenes::cornell(1);
        scene.materials[0] = Material {
            name: "mirror".into(),
            lambertian: Vec3::ZERO,
            glossy: Vec3::splat(0.9),
            exponent: f32::INFINITY,
            ..Material::default()
        };
        let all = trace(&scene, BsdfVariant::ALL);
        let no_delta = trace(
            &scene,
            BsdfVariant {
                glossy: true,
                delta: false,
            },
        );
        // Without the mirror lobe the mirror absorbs: the paths through it (the caustics) end
        // there, every other path is the same, so every photon stored is one of the full map's.
        assert!(no_delta.photons.len() < all.photons.len());
        let mut full: Vec<&[u8]> = all.photons.iter().map(bytemuck::bytes_of).collect();
        full.sort_unstable();
        for p in &no_delta.photons {
            assert!(
                full.binary_search(&bytemuck::bytes_of(p)).is_ok(),
                "{p:?} is not in the full photon map"
            );
        }
        // A wall of six is a mirror: many paths go through it.
        assert!(all.photons.len() - no_delta.photons.len() > 100);
    }

    #[test]
    fn pure_mirrors_and_glass_have_no_finite_lobe() {
        let mirror = Material {
            lambertian: Vec3::ZERO,
            glossy: Vec3::ONE,
            exponent: f32::INFINITY,
            ..Material::default()
        };
        let glass = Material {
            lambertian: Vec3::ZERO,
            transmission: Vec3::ONE,
            exponent: f32::INFINITY,
            fresnel: true,
            ..Material::default()
        };
        let glossy = Material {
            lambertian: Vec3::ZERO,
            glossy: Vec3::splat(0.5),
            exponent: 50.0,
            ..Material::default()
        };
        assert!(!has_finite_lobe(&Bsdf::new(&mirror, None)));
        assert!(!has_finite_lobe(&Bsdf::new(&glass, None)));
        assert!(has_finite_lobe(&Bsdf::new(&glossy, None)));
        assert!(has_finite_lobe(&Bsdf::new(&Material::default(), None)));
    }

    #[test]
    fn absorbed_or_empty_bounce_map_texels_start_no_path() {
        let empty = BounceMapPhoton::default();
        assert!(PhotonState::from_bounce_map(&empty, Vec3::ONE, 1e-4, 7).is_none());
        let lit = BounceMapPhoton::new(Vec3::ONE, Vec3::Y, 0.5, 1.0, 3.0);
        let s = PhotonState::from_bounce_map(&lit, Vec3::ZERO, 1e-4, 7).unwrap();
        assert_eq!(s.bounces, 1);
        assert!(s.origin.y > 0.0 && (s.rho_p - 0.5).abs() < 1e-6);
    }
}
