//! KHR_lights_punctual lights and perspective cameras of glTF nodes → [`Light`]s (in
//! radiometric units, [`units`](super::units)) and [`Camera`]s.

use super::units::{candela_to_watts_per_sr, lux_to_watts_per_m2};
use super::{rigid, Camera, Light, LightKind};
use anyhow::{ensure, Result};
use glam::{Mat4, Vec3};
use std::f32::consts::FRAC_PI_2;

/// One node's light at `world`; `None` (with a warning) when its transform collapses the
/// direction. Colour and intensity must be finite and ≥ 0; spot cones are checked by
/// [`spot_cone`].
pub fn convert_light(
    file: &str,
    light: &gltf::khr_lights_punctual::Light,
    world: Mat4,
) -> Result<Option<Light>> {
    let name = light
        .name()
        .map(str::to_owned)
        .unwrap_or_else(|| format!("light{}", light.index()));
    let color = Vec3::from_array(light.color());
    let intensity = light.intensity();
    ensure!(
        color.is_finite() && intensity.is_finite(),
        "light {name}: non-finite colour or intensity"
    );
    ensure!(
        color.cmpge(Vec3::ZERO).all() && intensity >= 0.0,
        "light {name}: negative colour or intensity"
    );
    let Some(direction) = world.transform_vector3(Vec3::NEG_Z).try_normalize() else {
        log::warn!("{file}: light {name}: node transform collapses its direction; light skipped");
        return Ok(None);
    };
    let position = world.transform_point3(Vec3::ZERO);
    use gltf::khr_lights_punctual::Kind;
    let (kind, scale) = match light.kind() {
        Kind::Point => (LightKind::Point, candela_to_watts_per_sr(intensity)),
        Kind::Directional => (LightKind::Directional, lux_to_watts_per_m2(intensity)),
        Kind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } => {
            let (inner, outer) = spot_cone(file, &name, inner_cone_angle, outer_cone_angle)?;
            (
                LightKind::Spot {
                    inner_cone_angle: inner,
                    outer_cone_angle: outer,
                },
                candela_to_watts_per_sr(intensity),
            )
        }
    };
    Ok(Some(Light {
        name,
        kind,
        position,
        direction,
        intensity: color * scale,
    }))
}

/// Validates spot cone angles: repairs small slips (with a warning), rejects nonsense.
fn spot_cone(file: &str, name: &str, inner: f32, outer: f32) -> Result<(f32, f32)> {
    const SLACK: f32 = 0.1;
    ensure!(
        inner.is_finite()
            && outer.is_finite()
            && outer > 0.0
            && outer <= FRAC_PI_2 + SLACK
            && inner >= -SLACK
            && inner <= outer + SLACK,
        "light {name}: absurd spot cone angles inner {inner}, outer {outer} (need 0 ≤ inner < outer ≤ π/2)"
    );
    let o = outer.min(FRAC_PI_2);
    let i = inner.max(0.0).min(o * 0.999);
    if (i, o) != (inner, outer) {
        log::warn!(
            "{file}: light {name}: spot cone angles ({inner}, {outer}) repaired to ({i}, {o})"
        );
    }
    Ok((i, o))
}

/// One node's camera at `world` (scale dropped); `None` (with a warning) for an orthographic one.
pub fn convert_camera(file: &str, camera: &gltf::Camera, world: Mat4) -> Result<Option<Camera>> {
    let name = camera
        .name()
        .map(str::to_owned)
        .unwrap_or_else(|| format!("camera{}", camera.index()));
    let p = match camera.projection() {
        gltf::camera::Projection::Perspective(p) => p,
        gltf::camera::Projection::Orthographic(_) => {
            log::warn!("{file}: camera {name}: orthographic cameras are not supported; skipped");
            return Ok(None);
        }
    };
    let (yfov, znear, zfar) = (p.yfov(), p.znear(), p.zfar());
    ensure!(
        yfov.is_finite() && yfov > 0.0 && yfov < std::f32::consts::PI,
        "camera {name}: yfov {yfov} outside (0, π)"
    );
    ensure!(
        znear.is_finite() && znear > 0.0,
        "camera {name}: znear {znear} must be > 0"
    );
    if let Some(f) = zfar {
        ensure!(
            f.is_finite() && f > znear,
            "camera {name}: zfar {f} must exceed znear {znear}"
        );
    }
    // Cameras are rigid: scale in the node hierarchy is dropped.
    Ok(Some(Camera {
        transform: rigid(world),
        yfov,
        znear,
        zfar,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spot_cone_slightly_off_is_repaired_and_absurd_is_rejected() {
        assert_eq!(spot_cone("f", "l", 0.2, 0.5).unwrap(), (0.2, 0.5));
        let (i, o) = spot_cone("f", "l", 0.5, FRAC_PI_2 + 0.05).unwrap();
        assert!(i < o && o <= FRAC_PI_2);
        let (i, o) = spot_cone("f", "l", 0.6, 0.6).unwrap();
        assert!(i < o);
        assert!(spot_cone("f", "l", 0.1, 3.0).is_err());
        assert!(spot_cone("f", "l", f32::NAN, 0.5).is_err());
    }
}
