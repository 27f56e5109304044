//! The one place where glTF's photometric light units become radiometric ones.
//!
//! KHR_lights_punctual gives point and spot intensity in candela (lm/sr) and directional
//! illuminance in lux (lm/m²). ispm transports power in watts. We use the luminous efficacy
//! of the photometric definition, 683 lm/W (exact at 555 nm), for every wavelength:
//!
//! ```text
//!   I [W/sr] = I [cd]  / 683        E [W/m²] = E [lx] / 683
//! ```
//!
//! Emission (glTF `emissiveFactor` × KHR_materials_emissive_strength, a luminance in nits =
//! cd/m²) follows the same rule (`gltf_material.rs`):
//!
//! ```text
//!   L_e [W/(m²·sr)] = L [nits] / 683
//! ```
//!
//! So the photometric power of every source maps to watts by the one factor 1/683: a point
//! light of I cd sends 4π·I lm = 4π·I/683 W, a one-sided Lambertian panel of luminance L and
//! area A sends π·L·A lm = π·(L/683)·A W (`scene::emitters`), and a panel and a point light of
//! the same lumens light a room equally (`tests/emission.rs` measures the mean irradiance of a
//! closed room under each: equal within 0.3 %).
//!
//! This is the convention of pbrt-v4 and Filament for "white" lights. It makes a light's
//! colour a pure chromaticity multiplier (linear RGB, as glTF stores it), and keeps the
//! numbers that reach the renderer at the scale an exposure of 0 EV expects.

/// Lumens per watt (photometric definition at 555 nm).
pub const LUMENS_PER_WATT: f32 = 683.0;

/// Candela (lm/sr) → W/sr; also nits (cd/m²) → W/(m²·sr), the emission's luminance.
pub fn candela_to_watts_per_sr(cd: f32) -> f32 {
    cd / LUMENS_PER_WATT
}

/// Lux (lm/m²) → W/m².
pub fn lux_to_watts_per_m2(lx: f32) -> f32 {
    lx / LUMENS_PER_WATT
}

/// W/sr → candela, for writing scenes.
pub fn watts_per_sr_to_candela(w: f32) -> f32 {
    w * LUMENS_PER_WATT
}

/// W/m² → lux, for writing scenes.
pub fn watts_per_m2_to_lux(w: f32) -> f32 {
    w * LUMENS_PER_WATT
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conversions_round_trip() {
        for v in [0.0f32, 1.0, 683.0, 1e6] {
            assert!((watts_per_sr_to_candela(candela_to_watts_per_sr(v)) - v).abs() <= v * 1e-6);
            assert!((watts_per_m2_to_lux(lux_to_watts_per_m2(v)) - v).abs() <= v * 1e-6);
        }
        assert_eq!(candela_to_watts_per_sr(683.0), 1.0);
    }
}
