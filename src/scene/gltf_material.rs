//! glTF materials → über-BSDF [`Material`]s, and base-colour images → [`Texture`]s.
//!
//! The mapping (documented with its reasons in `docs/scenes.md`), with base colour `c`,
//! metallic `m`, roughness `r`, transmission `t`, index of refraction `η`, specular factor `s`
//! and specular colour `sc`:
//!
//! ```text
//!   α = r²;  exponent σ = 2/α² − 2  (Blinn–Phong equivalent of GGX α; r = 0 or σ ≥ 1e6 ⇒ ∞, a mirror)
//!   F0 = ((η − 1)/(η + 1))² · s · sc
//!   glossy       = m·c + (1 − m)·F0
//!   lambertian   = (1 − m)·(1 − max F0)·(1 − t)·c   (glTF's fresnel_mix: the base × (1 − F))
//!   transmission = (1 − m)·(1 − max F0)·t·c
//!   fresnel      = m < 0.5          (dielectrics follow Fresnel, metals use `glossy` as is)
//!   emission     = emissiveFactor · emissiveStrength / 683   (nits → W/(m²·sr))
//! ```
//!
//! then, per channel, if lambertian + glossy + transmission > 1, lambertian and transmission are
//! scaled down so the sum is 1. Material `extras` `{"ispm": {...}}` override any field exactly.
//!
//! An emissiveTexture scales the emission by the texture's mean linear colour (emission is one
//! radiance per material: the emitter sampling and the shading read it), with a warning.
//!
//! Emission: a non-finite emissiveFactor or emissiveStrength is an error; a negative one is
//! clamped to 0, and an emitted radiance above [`MAX_EMISSION`] is scaled down to it, each with
//! a warning (a NaN or Inf radiance would make a NaN picture).
//!
//! KHR_materials_pbrSpecularGlossiness becomes metallic-roughness by the extension's published
//! conversion ([`spec_gloss_to_metal_rough`]); its diffuse texture is the base-colour texture.
//! KHR_materials_unlit becomes [`unlit`]: no reflectance, `emission` = base colour
//! (radiance c shows at about c with the default tonemap at 0 EV), `Material::unlit` set.

use super::gltf_data::{read_uri, Buffers};
use super::units::candela_to_watts_per_sr;
use super::{Material, Texture, TextureId, MAX_EMISSION};
use anyhow::{anyhow, bail, ensure, Context, Result};
use glam::Vec3;
use serde::Deserialize;
use std::collections::HashMap;
use std::path::Path;

/// Exponents at or above this are treated as a perfect mirror.
const MIRROR_EXPONENT: f64 = 1e6;
/// F0 of a dielectric in the specular-glossiness conversion (η = 1.5).
const DIELECTRIC_F0: f32 = 0.04;
/// Largest texture side we decode.
const MAX_TEXTURE_SIDE: u32 = 16384;
/// Most decoded texture bytes (all images together) a scene may hold.
const MAX_TEXTURE_BYTES: usize = 1 << 30;

/// The `{"ispm": {...}}` material extras: exact über-BSDF parameters.
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct IspmExtras {
    lambertian: Option<[f32; 3]>,
    glossy: Option<[f32; 3]>,
    exponent: Option<Exponent>,
    transmission: Option<[f32; 3]>,
    ior: Option<f32>,
    fresnel: Option<bool>,
    emission: Option<[f32; 3]>,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum Exponent {
    Number(f32),
    Word(String),
}

#[derive(Deserialize)]
struct Extras {
    ispm: Option<IspmExtras>,
}

fn finite3(v: [f32; 3], what: &str) -> Result<Vec3> {
    let v = Vec3::from_array(v);
    ensure!(v.is_finite(), "non-finite {what} {v}");
    Ok(v)
}

fn reflectance(v: [f32; 3], what: &str, file: &str, name: &str) -> Result<Vec3> {
    let v = finite3(v, what)?;
    let c = v.clamp(Vec3::ZERO, Vec3::ONE);
    if c != v {
        log::warn!("{file}: material {name}: {what} {v} clamped to [0, 1]");
    }
    Ok(c)
}

/// Blinn–Phong exponent for a glTF perceptual roughness.
pub fn exponent_from_roughness(r: f32) -> f32 {
    let alpha = (r as f64).clamp(0.0, 1.0).powi(2);
    if alpha == 0.0 {
        return f32::INFINITY;
    }
    let sigma = 2.0 / (alpha * alpha) - 2.0;
    if sigma >= MIRROR_EXPONENT {
        f32::INFINITY
    } else {
        sigma.max(0.0) as f32
    }
}

/// Converts material `index` of the document (texture ids come from `textures`).
pub fn convert_material(
    file: &str,
    mat: &gltf::Material,
    textures: &mut TextureCache,
) -> Result<Material> {
    let name = mat
        .name()
        .map(str::to_owned)
        .unwrap_or_else(|| format!("material{}", mat.index().unwrap_or(0)));
    let what = format!("material {name}");
    convert_inner(file, &name, mat, textures).with_context(|| what)
}

/// The base colour, metallic and roughness of a material, and its base-colour texture: from
/// pbrMetallicRoughness, or converted from KHR_materials_pbrSpecularGlossiness.
struct BaseModel<'a> {
    color: Vec3,
    metallic: f32,
    roughness: f32,
    texture: Option<gltf::texture::Info<'a>>,
}

fn base_model<'a>(file: &str, name: &str, mat: &gltf::Material<'a>) -> Result<BaseModel<'a>> {
    if let Some(sg) = mat.pbr_specular_glossiness() {
        let [r, g, b, _a] = sg.diffuse_factor();
        let diffuse = reflectance([r, g, b], "diffuseFactor", file, name)?;
        let specular = reflectance(sg.specular_factor(), "specularFactor", file, name)?;
        let gloss = sg.glossiness_factor();
        ensure!(gloss.is_finite(), "non-finite glossinessFactor {gloss}");
        if sg.specular_glossiness_texture().is_some() {
            log::warn!(
                "{file}: material {name}: specularGlossinessTexture is not used (its factors are)"
            );
        }
        let (color, metallic) = spec_gloss_to_metal_rough(diffuse, specular);
        return Ok(BaseModel {
            color,
            metallic,
            roughness: 1.0 - gloss.clamp(0.0, 1.0),
            texture: sg.diffuse_texture(),
        });
    }
    let pbr = mat.pbr_metallic_roughness();
    let [r, g, b, _a] = pbr.base_color_factor();
    let color = reflectance([r, g, b], "baseColorFactor", file, name)?;
    let (metallic, roughness) = (pbr.metallic_factor(), pbr.roughness_factor());
    ensure!(
        metallic.is_finite() && roughness.is_finite(),
        "non-finite metallic/roughness factor"
    );
    Ok(BaseModel {
        color,
        metallic: metallic.clamp(0.0, 1.0),
        roughness,
        texture: pbr.base_color_texture(),
    })
}

/// KHR_materials_pbrSpecularGlossiness (diffuse, specular) → metallic-roughness (base colour,
/// metallic), by the conversion published with the extension (glTF repository,
/// `KHR_materials_pbrSpecularGlossiness/examples/convert-between-workflows`): metallic solves
/// the quadratic that blends a dielectric (F0 = 0.04) with a metal on the perceived brightness
/// √(0.299 r² + 0.587 g² + 0.114 b²) of diffuse and specular; the base colour blends the
/// colour seen as diffuse and the colour seen as specular by metallic². Glossiness becomes
/// roughness = 1 − glossiness (in [`base_model`]).
pub fn spec_gloss_to_metal_rough(diffuse: Vec3, specular: Vec3) -> (Vec3, f32) {
    const EPSILON: f32 = 1e-6;
    let brightness = |c: Vec3| (0.299 * c.x * c.x + 0.587 * c.y * c.y + 0.114 * c.z * c.z).sqrt();
    let one_minus_specular = 1.0 - specular.max_element();
    let (d, s) = (brightness(diffuse), brightness(specular));
    let metallic = if s < DIELECTRIC_F0 {
        0.0
    } else {
        let a = DIELECTRIC_F0;
        let b = d * one_minus_specular / (1.0 - DIELECTRIC_F0) + s - 2.0 * DIELECTRIC_F0;
        let c = DIELECTRIC_F0 - s;
        let discriminant = (b * b - 4.0 * a * c).max(0.0);
        ((-b + discriminant.sqrt()) / (2.0 * a)).clamp(0.0, 1.0)
    };
    let from_diffuse =
        diffuse * (one_minus_specular / (1.0 - DIELECTRIC_F0) / (1.0 - metallic).max(EPSILON));
    let from_specular =
        (specular - Vec3::splat(DIELECTRIC_F0 * (1.0 - metallic))) / metallic.max(EPSILON);
    let color = from_diffuse
        .lerp(from_specular, metallic * metallic)
        .clamp(Vec3::ZERO, Vec3::ONE);
    (color, metallic)
}

/// A KHR_materials_unlit material: shown at its base colour (times the mean colour of its
/// base-colour texture, which is not sampled per pixel), reflecting nothing.
fn unlit(
    file: &str,
    name: &str,
    mat: &gltf::Material,
    textures: &mut TextureCache,
) -> Result<Material> {
    let base = base_model(file, name, mat)?;
    let mut color = base.color;
    if let Some(info) = base.texture {
        color *= textures.mean_linear(&info.texture().source())?;
        log::warn!(
            "{file}: material {name}: unlit base-colour texture shown as its mean colour {color}"
        );
    }
    Ok(Material {
        name: name.to_owned(),
        lambertian: Vec3::ZERO,
        glossy: Vec3::ZERO,
        transmission: Vec3::ZERO,
        emission: color,
        double_sided: mat.double_sided(),
        unlit: true,
        ..Material::default()
    })
}

/// The emitted radiance of emissiveFactor × KHR_materials_emissive_strength, in W/(m²·sr):
/// non-finite is an error; negative is clamped to 0 with a warning.
fn emission(file: &str, name: &str, mat: &gltf::Material) -> Result<Vec3> {
    let factor = finite3(mat.emissive_factor(), "emissiveFactor")?;
    let strength = mat.emissive_strength().unwrap_or(1.0);
    ensure!(
        strength.is_finite(),
        "non-finite emissiveStrength {strength}"
    );
    let clamped = factor.max(Vec3::ZERO);
    if clamped != factor {
        log::warn!("{file}: material {name}: negative emissiveFactor {factor} clamped to 0");
    }
    if strength < 0.0 {
        log::warn!("{file}: material {name}: negative emissiveStrength {strength} clamped to 0");
    }
    Ok(clamped * candela_to_watts_per_sr(strength.max(0.0)))
}

/// Scales an emitted radiance brighter than [`MAX_EMISSION`] down to it (keeping its colour).
fn limit_emission(file: &str, m: &mut Material) {
    let peak = m.emission.max_element();
    if peak > MAX_EMISSION {
        log::warn!(
            "{file}: material {}: emitted radiance {} W/(m²·sr) scaled down to {MAX_EMISSION} \
             (emissiveFactor × emissiveStrength is absurdly bright)",
            m.name,
            m.emission
        );
        m.emission *= MAX_EMISSION / peak;
    }
}

fn convert_inner(
    file: &str,
    name: &str,
    mat: &gltf::Material,
    textures: &mut TextureCache,
) -> Result<Material> {
    if mat.unlit() {
        return unlit(file, name, mat, textures);
    }
    let base = base_model(file, name, mat)?;
    let (c, m, rough) = (base.color, base.metallic, base.roughness);
    let t = mat.transmission().map_or(0.0, |t| t.transmission_factor());
    let ior = mat.ior().unwrap_or(1.5);
    let (s, sc) = mat.specular().map_or((1.0, [1.0; 3]), |s| {
        (s.specular_factor(), s.specular_color_factor())
    });
    ensure!(
        t.is_finite() && ior.is_finite() && s.is_finite(),
        "non-finite transmission, ior or specular factor"
    );
    let sc = finite3(sc, "specularColorFactor")?;
    let t = t.clamp(0.0, 1.0);
    ensure!(ior >= 1.0 || ior == 0.0, "ior {ior} is below 1");
    // KHR_materials_ior: ior 0 means "no dielectric specular" in some exporters; treat as 1.5.
    let ior = if ior == 0.0 { 1.5 } else { ior };
    let f0 = (((ior - 1.0) / (ior + 1.0)).powi(2) * s.clamp(0.0, 1.0) * sc).min(Vec3::ONE);

    // glTF's fresnel_mix weights the dielectric base (diffuse and transmission) by 1 − F,
    // F = F0 at normal incidence; the Fresnel ramp (`fresnel`) takes it from there to grazing.
    let base_weight = (1.0 - m) * (1.0 - f0.max_element());
    let mut out = Material {
        name: name.to_owned(),
        lambertian: base_weight * (1.0 - t) * c,
        lambertian_texture: None,
        glossy: m * c + (1.0 - m) * f0,
        exponent: exponent_from_roughness(rough),
        transmission: base_weight * t * c,
        ior,
        fresnel: m < 0.5,
        emission: emission(file, name, mat)?,
        double_sided: mat.double_sided(),
        unlit: false,
    };
    if let Some(info) = base.texture {
        if info.tex_coord() != 0 {
            log::warn!("{file}: material {name}: base colour texture uses TEXCOORD_{}; only TEXCOORD_0 is loaded", info.tex_coord());
        }
        if info.texture_transform().is_some() {
            log::warn!("{file}: material {name}: KHR_texture_transform is not applied yet");
        }
        out.lambertian_texture = Some(textures.get(&info.texture().source())?);
    }
    if let Some(info) = mat.emissive_texture() {
        // Emission is a per-material radiance (the area-sample lights, the references' emitter
        // sampling and the shading all read it): an emissive texture counts as its mean colour,
        // so the surface emits its whole power, evenly.
        let mean = textures.mean_linear(&info.texture().source())?;
        out.emission *= mean;
        log::warn!(
            "{file}: material {name}: emissive texture applied as its mean colour {mean} (not \
             sampled per pixel)"
        );
    }
    if let Some(raw) = mat.extras() {
        let extras: Extras =
            serde_json::from_str(raw.get()).map_err(|e| anyhow!("bad \"ispm\" extras: {e}"))?;
        if let Some(x) = extras.ispm {
            apply_extras(&mut out, x)?;
        }
    }
    limit_emission(file, &mut out);
    enforce_energy(file, &mut out);
    Ok(out)
}

fn apply_extras(out: &mut Material, x: IspmExtras) -> Result<()> {
    let unit = |v: [f32; 3], what: &str| -> Result<Vec3> {
        let v = finite3(v, what)?;
        ensure!(
            v.cmpge(Vec3::ZERO).all() && v.cmple(Vec3::ONE).all(),
            "ispm {what} {v} outside [0, 1]"
        );
        Ok(v)
    };
    if let Some(v) = x.lambertian {
        out.lambertian = unit(v, "lambertian")?;
    }
    if let Some(v) = x.glossy {
        out.glossy = unit(v, "glossy")?;
    }
    if let Some(v) = x.transmission {
        out.transmission = unit(v, "transmission")?;
    }
    if let Some(e) = x.exponent {
        out.exponent = match e {
            Exponent::Word(w) if w == "inf" => f32::INFINITY,
            Exponent::Word(w) => bail!("ispm exponent {w:?} is neither a number nor \"inf\""),
            Exponent::Number(n) => {
                ensure!(
                    n.is_finite() && n >= 0.0,
                    "ispm exponent {n} must be finite and ≥ 0"
                );
                n
            }
        };
    }
    if let Some(ior) = x.ior {
        ensure!(
            ior.is_finite() && ior >= 1.0,
            "ispm ior {ior} must be finite and ≥ 1"
        );
        out.ior = ior;
    }
    if let Some(f) = x.fresnel {
        out.fresnel = f;
    }
    if let Some(e) = x.emission {
        let e = finite3(e, "emission")?;
        ensure!(e.cmpge(Vec3::ZERO).all(), "ispm emission {e} is negative");
        out.emission = e;
    }
    Ok(())
}

/// Keeps lambertian + glossy + transmission ≤ 1 per channel by scaling the first and last.
fn enforce_energy(file: &str, m: &mut Material) {
    let sum = m.lambertian + m.glossy + m.transmission;
    if sum.cmple(Vec3::splat(1.0 + 1e-6)).all() {
        return;
    }
    let room = (Vec3::ONE - m.glossy).max(Vec3::ZERO);
    let rest = m.lambertian + m.transmission;
    let scale = Vec3::select(rest.cmpgt(room), room / rest, Vec3::ONE);
    let explicit = m.glossy.cmpgt(Vec3::ONE).any();
    m.glossy = m.glossy.min(Vec3::ONE);
    m.lambertian *= scale;
    m.transmission *= scale;
    if explicit || scale.min_element() < 0.999 {
        log::warn!(
            "{file}: material {}: reflectances summed to {sum} > 1; lambertian and transmission scaled down",
            m.name
        );
    }
}

/// Decoded base-colour images, one [`Texture`] per glTF image.
pub struct TextureCache<'a, 'b> {
    pub buffers: &'b Buffers<'a>,
    pub base_dir: Option<&'b Path>,
    pub textures: Vec<Texture>,
    by_image: HashMap<usize, TextureId>,
    bytes: usize,
}

impl<'a, 'b> TextureCache<'a, 'b> {
    pub fn new(buffers: &'b Buffers<'a>, base_dir: Option<&'b Path>) -> Self {
        Self {
            buffers,
            base_dir,
            textures: Vec::new(),
            by_image: HashMap::new(),
            bytes: 0,
        }
    }

    /// The scene texture of `image`, decoded once.
    fn get(&mut self, image: &gltf::Image) -> Result<TextureId> {
        if let Some(&id) = self.by_image.get(&image.index()) {
            return Ok(id);
        }
        let texture = self.decode(image)?;
        let id = self.textures.len();
        self.textures.push(texture);
        self.by_image.insert(image.index(), id);
        Ok(id)
    }

    /// The mean linear colour of `image` (decoded, not kept as a scene texture unless it is
    /// one already).
    fn mean_linear(&mut self, image: &gltf::Image) -> Result<Vec3> {
        match self.by_image.get(&image.index()) {
            Some(&id) => Ok(self.textures[id].mean_linear()),
            None => Ok(self.decode(image)?.mean_linear()),
        }
    }

    fn decode(&mut self, image: &gltf::Image) -> Result<Texture> {
        let what = format!("image {}", image.index());
        let bytes = match image.source() {
            gltf::image::Source::View { view, .. } => self.buffers.view(&view)?.to_vec(),
            gltf::image::Source::Uri { uri, .. } => read_uri(uri, self.base_dir, &what)?,
        };
        let texture = decode_image(&bytes).with_context(|| what.clone())?;
        self.bytes += texture.rgba8.len();
        ensure!(
            self.bytes <= MAX_TEXTURE_BYTES,
            "absurd size: decoded textures exceed {MAX_TEXTURE_BYTES} bytes at {what}"
        );
        Ok(Texture {
            name: image.name().map(str::to_owned).unwrap_or(what),
            ..texture
        })
    }
}

impl Texture {
    /// The mean of the texels' linear RGB (sRGB decoded).
    pub fn mean_linear(&self) -> Vec3 {
        let decode = |v: u8| {
            let c = f32::from(v) / 255.0;
            if c <= 0.04045 {
                c / 12.92
            } else {
                ((c + 0.055) / 1.055).powf(2.4)
            }
        };
        let texels = self.rgba8.chunks_exact(4);
        let n = texels.len().max(1) as f32;
        texels.fold(Vec3::ZERO, |sum, t| {
            sum + Vec3::new(decode(t[0]), decode(t[1]), decode(t[2]))
        }) / n
    }
}

fn decode_image(bytes: &[u8]) -> Result<Texture> {
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .context("cannot read image")?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_TEXTURE_SIDE);
    limits.max_image_height = Some(MAX_TEXTURE_SIDE);
    limits.max_alloc = Some(MAX_TEXTURE_BYTES as u64);
    reader.limits(limits);
    let img = reader
        .decode()
        .map_err(|e| anyhow!("cannot decode image: {e}"))?;
    let rgba = img.to_rgba8();
    Ok(Texture {
        name: String::new(),
        width: rgba.width(),
        height: rgba.height(),
        rgba8: rgba.into_raw(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roughness_maps_to_blinn_phong_exponent() {
        assert_eq!(exponent_from_roughness(0.0), f32::INFINITY);
        assert_eq!(exponent_from_roughness(1.0), 0.0);
        let a = 0.5f32 * 0.5;
        assert!((exponent_from_roughness(0.5) - (2.0 / (a * a) - 2.0)).abs() < 1e-3);
        assert_eq!(exponent_from_roughness(1e-4), f32::INFINITY);
    }

    #[test]
    fn energy_is_kept_at_most_one_per_channel() {
        let mut m = Material {
            lambertian: Vec3::splat(0.9),
            glossy: Vec3::splat(0.5),
            transmission: Vec3::splat(0.3),
            ..Default::default()
        };
        enforce_energy("f", &mut m);
        let sum = m.lambertian + m.glossy + m.transmission;
        assert!(sum.max_element() <= 1.0 + 1e-5, "{sum}");
        assert_eq!(m.glossy, Vec3::splat(0.5));
    }

    #[test]
    fn the_fresnel_ramp_share_is_one_minus_the_gltf_roughness_of_the_exponent() {
        use crate::photon::bsdf::fresnel_ramp_share;
        assert_eq!(fresnel_ramp_share(f32::INFINITY), 1.0);
        assert_eq!(fresnel_ramp_share(0.0), 0.0);
        assert_eq!(fresnel_ramp_share(f32::NAN), 0.0);
        for r in [0.1f32, 0.25, 0.5, 0.75, 0.9] {
            let share = fresnel_ramp_share(exponent_from_roughness(r));
            assert!((share - (1.0 - r)).abs() < 1e-4, "r {r}: share {share}");
        }
    }
}
