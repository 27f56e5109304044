//! White furnace of glTF metallic-roughness materials (issue #19): the directional albedo
//! `∫ f cos dωi` of the über-BSDF that the loader makes of a glTF material, against the BRDF
//! the glTF 2.0 specification defines for it (appendix B: a Fresnel mix, F = F0 + (1 − F0)
//! (1 − |V·H|)⁵ with F0 = 0.04, of a Lambertian base and a GGX specular layer with α = r²,
//! height-correlated Smith visibility; metals: the layer with Schlick's F0 = base colour).
//!
//! What must hold: a white material reflects at most 1 at every angle, a white Lambertian
//! exactly 1, and every configuration stays near glTF's albedo where glTF's is physical. The
//! deliberate differences, measured here and recorded in `docs/scenes.md`:
//! - glTF's single-scattering GGX layer loses the light of the microfacets' multiple
//!   bounces (a white metal of roughness 1 keeps 0.31 at normal incidence); the über-BSDF's
//!   glossy lobe is energy-compensated (`photon::bsdf`, "Glossy energy compensation") and
//!   keeps its reflectance, as renderers with multiple-scattering compensation do.
//! - glTF's dielectric mix is not energy-conserving at grazing angles (a white dielectric of
//!   roughness 0.2 reflects 1.48 at cos θo = 0.05); the über-BSDF never exceeds 1.
//!
//! `cargo test --test physics_gltf_brdf -- --nocapture` prints the table.

mod common;

use common::gltf_doc::object_on_floor;
use glam::Vec3;
use ispm::photon::bsdf::Bsdf;
use ispm::photon::rng::Rng;
use rayon::prelude::*;
use serde_json::json;
use std::f32::consts::PI;

const COS_O: [f32; 5] = [1.0, 0.7, 0.4, 0.2, 0.05];
const SAMPLES: usize = 200_000;

fn wo(cos_o: f32) -> Vec3 {
    Vec3::new((1.0 - cos_o * cos_o).sqrt(), 0.0, cos_o)
}

/// The glTF specification's BRDF (appendix B) for a grey base colour `c`, roughness `r`,
/// metallic `m`, times cos θi.
fn gltf_brdf_cos(c: f32, r: f32, m: f32, wo: Vec3, wi: Vec3) -> f32 {
    let (nl, nv) = (wi.z, wo.z);
    if nl <= 0.0 || nv <= 0.0 {
        return 0.0;
    }
    let h = (wi + wo).normalize();
    let (nh, vh) = (h.z, wo.dot(h).abs());
    let a2 = (r * r).powi(2);
    let d = a2 / (PI * (nh * nh * (a2 - 1.0) + 1.0).powi(2));
    let vis =
        0.5 / (nl * (nv * nv * (1.0 - a2) + a2).sqrt() + nv * (nl * nl * (1.0 - a2) + a2).sqrt());
    let specular = vis * d;
    let schlick = (1.0 - vh).powi(5);
    let fr = 0.04 + 0.96 * schlick;
    let dielectric = (1.0 - fr) * c / PI + fr * specular;
    let metal = (c + (1.0 - c) * schlick) * specular;
    ((1.0 - m) * dielectric + m * metal) * nl
}

/// glTF's directional albedo by cosine-weighted Monte Carlo.
fn gltf_albedo(c: f32, r: f32, m: f32, cos_o: f32) -> f32 {
    let mut rng = Rng::new(5);
    let sum: f64 = (0..SAMPLES)
        .map(|_| {
            let u = rng.next_2();
            let (s, phi) = (u[0].sqrt(), 2.0 * PI * u[1]);
            let wi = Vec3::new(s * phi.cos(), s * phi.sin(), (1.0 - u[0]).sqrt());
            // pdf cos/π: estimator f cos · π / cos.
            f64::from(gltf_brdf_cos(c, r, m, wo(cos_o), wi) * PI / wi.z.max(1e-7))
        })
        .sum();
    (sum / SAMPLES as f64) as f32
}

/// The über-BSDF's directional albedo (red channel) from its own sampling weights.
fn our_albedo(b: &Bsdf, cos_o: f32) -> f32 {
    albedo_n(b, cos_o, SAMPLES, 7)
}

/// The über-BSDFs the loader makes of glTF materials `(c, r, m)` (no extras).
fn loaded(configs: &[(f32, f32, f32)]) -> Vec<Bsdf> {
    let materials: Vec<_> = configs
        .iter()
        .map(|&(c, r, m)| {
            json!({"pbrMetallicRoughness": {"baseColorFactor": [c, c, c, 1.0],
                   "metallicFactor": m, "roughnessFactor": r}})
        })
        .collect();
    loaded_json(materials, "materials")
}

/// The über-BSDFs the loader makes of glTF material objects, written into one file `name`
/// (every material extension the loader reads declared as used).
fn loaded_json(materials: Vec<serde_json::Value>, name: &str) -> Vec<Bsdf> {
    let mut doc = object_on_floor();
    doc.doc["materials"] = json!(materials);
    for ext in [
        "KHR_materials_transmission",
        "KHR_materials_ior",
        "KHR_materials_specular",
        "KHR_materials_pbrSpecularGlossiness",
    ] {
        doc.uses(ext, false);
    }
    let dir = common::image_dir("physics_gltf_brdf");
    let scene = ispm::scene::load::load(&doc.write(&dir, name)).expect("load");
    scene.materials.iter().map(|m| Bsdf::new(m, None)).collect()
}

/// The über-BSDF's directional albedo (red channel) with `n` samples and a seed of its own.
fn albedo_n(b: &Bsdf, cos_o: f32, n: usize, seed: u32) -> f32 {
    let mut rng = Rng::new(seed);
    let sum: f64 = (0..n)
        .filter_map(|_| b.sample(wo(cos_o), Vec3::Z, Vec3::Z, rng.next_3()))
        .map(|s| f64::from(s.weight.x))
        .sum();
    (sum / n as f64) as f32
}

#[test]
fn every_white_material_the_loader_makes_keeps_all_light_and_gains_none() {
    // A white furnace over every configuration the metallic-roughness loader can produce:
    // roughness × metallic × transmission × ior × KHR_materials_specular, plus
    // KHR_materials_pbrSpecularGlossiness. With a white base, glTF's fresnel_mix splits the
    // light between the base (diffuse or transmission) and the specular layer, and a white
    // metal reflects everything: the über-BSDF must then keep all the light it gets, at every
    // angle — reflected plus transmitted — and never more. Spec-gloss materials are converted
    // by the extension's formula, whose white is not always energy-preserving: they are held to
    // "no gain" only.
    const N: usize = 50_000;
    let mut configs = Vec::new();
    for r in [0.0f32, 0.05, 0.2, 0.5, 0.8, 1.0] {
        for m in [0.0f32, 0.3, 0.7, 1.0] {
            for t in [0.0f32, 0.5, 1.0] {
                for ior in [1.0f32, 1.33, 1.5, 2.4] {
                    for (s, sc) in [(1.0f32, [1.0f32; 3]), (0.5, [1.0, 1.0, 1.0])] {
                        configs.push((
                            format!("r {r} m {m} t {t} ior {ior} specular {s}"),
                            json!({"pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0],
                                    "metallicFactor": m, "roughnessFactor": r},
                                   "extensions": {
                                       "KHR_materials_transmission": {"transmissionFactor": t},
                                       "KHR_materials_ior": {"ior": ior},
                                       "KHR_materials_specular": {"specularFactor": s,
                                                                  "specularColorFactor": sc}}}),
                            true,
                        ));
                    }
                }
            }
        }
    }
    for gloss in [0.0f32, 0.5, 1.0] {
        for (d, sp) in [(1.0f32, 0.04f32), (0.5, 0.5), (0.0, 1.0), (1.0, 1.0)] {
            configs.push((
                format!("spec-gloss diffuse {d} specular {sp} glossiness {gloss}"),
                json!({"extensions": {"KHR_materials_pbrSpecularGlossiness": {
                    "diffuseFactor": [d, d, d, 1.0], "specularFactor": [sp, sp, sp],
                    "glossinessFactor": gloss}}}),
                false,
            ));
        }
    }
    let bsdfs = loaded_json(configs.iter().map(|c| c.1.clone()).collect(), "furnace");
    let (mut lowest, mut highest, mut sum_range) = (f32::MAX, f32::MIN, (f32::MAX, f32::MIN));
    for ((what, _, conserving), b) in configs.iter().zip(&bsdfs) {
        // Exactly: the lobes' reflectances at ωo, Σ c_j, are the light the BSDF hands on (each
        // lobe's shape reflects its c_j: Lambertian and delta lobes exactly, the compensated
        // glossy lobe to ±0.5 %, `a_white_lambertian_reflects_exactly_one…`).
        for k in 0..=64 {
            let cos_o = 1.0 - k as f32 / 64.0 * 0.99;
            let sum: f32 = b.albedo_weights(wo(cos_o), Vec3::Z, Vec3::Z).iter().sum();
            assert!(
                sum <= 1.0 + 1e-5,
                "{what} at cos θo {cos_o}: lobe reflectances sum to {sum} > 1"
            );
            if *conserving {
                sum_range = (sum_range.0.min(sum), sum_range.1.max(sum));
                assert!(
                    sum >= 1.0 - 1e-5,
                    "{what} at cos θo {cos_o}: lobe reflectances sum to {sum} < 1"
                );
            }
        }
    }
    // By sampling, as the tracers see it: 50k samples a point; the mean's noise (largest at
    // σ = 0, whose weights reach 1/E ≈ 7) over 2 940 points and the glossy table's ±0.5 %
    // take the bounds to ±1.5 % (measured 0.990–1.011; 0.995–1.006 at 100k samples).
    let sampled: Vec<Vec<f32>> = bsdfs
        .par_iter()
        .map(|b| {
            (COS_O.iter().enumerate())
                .map(|(k, &cos_o)| albedo_n(b, cos_o, N, 11 + k as u32))
                .collect()
        })
        .collect();
    for ((what, _, conserving), albedos) in configs.iter().zip(&sampled) {
        for (cos_o, &a) in COS_O.into_iter().zip(albedos) {
            assert!(
                a <= 1.015,
                "{what} at cos θo {cos_o}: sampled albedo {a} > 1 (gains energy)"
            );
            if *conserving {
                lowest = lowest.min(a);
                highest = highest.max(a);
                assert!(
                    a >= 0.985,
                    "{what} at cos θo {cos_o}: sampled albedo {a} < 1 (a white material loses \
                     light)"
                );
            }
        }
    }
    eprintln!(
        "{} configurations: white metallic-roughness lobe sums in [{:.6}, {:.6}], sampled \
         albedo in [{lowest:.4}, {highest:.4}]",
        configs.len(),
        sum_range.0,
        sum_range.1
    );
}

#[test]
fn gltf_materials_reflect_at_most_one_and_near_the_gltf_brdf() {
    // (base colour, roughness, metallic), and the largest |ours − glTF| allowed at each angle
    // where glTF's albedo is ≤ 1 (just above the worst measured, cos θo = 1 … 0.05).
    let cases: [((f32, f32, f32), f32); 8] = [
        // White rough dielectric: 0.999–1.001 against glTF's 0.972–1.001.
        ((1.0, 1.0, 0.0), 0.04),
        // Grey rough dielectrics: the Fresnel ramp scaled by 1 − r (fresnel_ramp_share) follows
        // glTF's F(V·H) of a rough surface: 0.808 flat vs 0.780–0.814 at r = 1, 0.520–0.699
        // vs 0.517–0.668 at r = 0.5 (with the full ramp: up to 0.952 and 0.875, 0.14 and 0.21
        // above glTF at grazing).
        ((0.8, 1.0, 0.0), 0.035),
        ((1.0, 0.5, 0.0), 0.02),
        ((0.5, 0.5, 0.0), 0.04),
        // Smooth metal (glTF's estimate is noisy here: a sharp lobe, cosine-sampled).
        ((1.0, 0.2, 1.0), 0.05),
        // Rough metals, energy-compensated: 1.0 against glTF's 0.84–0.94 and 0.31–0.85.
        ((1.0, 0.5, 1.0), 0.17),
        ((1.0, 1.0, 1.0), 0.70),
        // Smooth dielectric: a mirror lobe, no finite glTF integral (only the bound).
        ((0.9, 0.0, 0.0), 0.0),
    ];
    let configs: Vec<_> = cases.iter().map(|c| c.0).collect();
    let bsdfs = loaded(&configs);
    for (((c, r, m), tolerance), b) in cases.iter().zip(&bsdfs) {
        let mut line = format!("c {c} r {r} m {m}:");
        for cos_o in COS_O {
            let ours = our_albedo(b, cos_o);
            line += &format!(" {cos_o}: {ours:.3}");
            assert!(
                ours <= 1.0 + 5e-3,
                "c {c} r {r} m {m} at cos θo {cos_o}: albedo {ours} > 1"
            );
            if *r > 0.0 {
                let theirs = gltf_albedo(*c, *r, *m, cos_o);
                line += &format!(" (glTF {theirs:.3})");
                if theirs <= 1.0 {
                    assert!(
                        (ours - theirs).abs() <= *tolerance,
                        "c {c} r {r} m {m} at cos θo {cos_o}: {ours} vs glTF {theirs}"
                    );
                }
            }
        }
        eprintln!("{line}");
    }
}

#[test]
fn a_white_lambertian_reflects_exactly_one_and_a_white_rough_glossy_lobe_too() {
    use ispm::scene::Material;
    let white = |lambertian: f32, glossy: f32| {
        Bsdf::new(
            &Material {
                lambertian: Vec3::splat(lambertian),
                glossy: Vec3::splat(glossy),
                exponent: 0.0,
                transmission: Vec3::ZERO,
                fresnel: false,
                ..Material::default()
            },
            None,
        )
    };
    for cos_o in COS_O {
        // Every Lambertian sample weighs exactly c_L: no sample is lost.
        let a = our_albedo(&white(1.0, 0.0), cos_o);
        assert!((a - 1.0).abs() <= 1e-6, "Lambertian at cos θo {cos_o}: {a}");
        // σ = 0, the roughest lobe: 0.14 to 0.45 before the energy compensation.
        let a = our_albedo(&white(0.0, 1.0), cos_o);
        assert!(
            (a - 1.0).abs() <= 0.01,
            "glossy σ = 0 at cos θo {cos_o}: {a}"
        );
    }
}
