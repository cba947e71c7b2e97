//! Point, spot and directional lights (`[[lights]]`), Mitsuba 3's `point`,
//! `spot` and `directional` emitters: delta lights, which no sampled direction
//! can hit (and no camera ray sees), so every strategy estimates them by a
//! shadow ray at each path vertex with a smooth lobe (the kernel's
//! `DELTA_LIGHTS`; `lights::pack_delta_lights` packs them).
//!
//! ```toml
//! [[lights]]
//! type = "spot"
//! position = [0, 3, 0]
//! direction = [0, -1, 0]
//! intensity = [10, 9, 8]
//! cutoff_angle = 30
//! ```
//!
//! - `type = "point"`: `position` (vector, required) and `intensity` (radiant
//!   intensity in W/sr: a vector, or one number for grey, components >= 0,
//!   required). A surface at distance `d` whose normal makes the angle `theta`
//!   with the direction to the light receives the irradiance `intensity
//!   cos(theta) / d^2`.
//! - `type = "spot"`: the same, and `direction` (vector, not zero: the cone's
//!   axis, pointing away from the light), `cutoff_angle` (degrees in (0, 180),
//!   default 20) and `beam_width` (degrees in [0, cutoff_angle], default
//!   `cutoff_angle * 3/4`). The intensity toward a direction at the angle `a`
//!   from the axis is multiplied by Mitsuba's falloff (`spot.cpp`): 1 within
//!   the beam width, 0 at and beyond the cutoff, `(cutoff - a) / (cutoff -
//!   beam_width)` between.
//! - `type = "directional"`: a light at infinity (the sun), `direction` (vector,
//!   not zero, required: the way its light travels) and `irradiance` (W/m^2 on
//!   a surface facing it: a vector, or one number for grey, components >= 0,
//!   required). A surface whose normal makes the angle `theta` with `-direction`
//!   receives `irradiance cos(theta)` wherever nothing stands between it and
//!   the light: its shadow ray has no end. The scene's size plays no part (as
//!   in Mitsuba, whose `irradiance` is per unit area perpendicular to the
//!   direction), except in how often a vertex picks it among many delta lights
//!   (by `irradiance` times the area of the disk of the scene's extent).
//!
//! `[scene] scale` moves point and spot lights with the geometry and multiplies
//! their intensity by `scale^2`; a directional light's irradiance stays.
//! Mitsuba's `point`, `spot` and `directional` emitters become `[[lights]]`
//! tables read here (`scene::mitsuba`).

use super::params::{
    ParamTable, Result, check_nonneg, check_open_angle, colour, fmt_num, ok, unknown_name,
};
use super::usable_length_squared;
use glam::Vec3;
use serde::Serialize;

/// A light at a point: a delta light, which no sampled direction can hit, so
/// every strategy estimates it by a shadow ray (next-event estimation) at each
/// vertex with a smooth lobe.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PointLight {
    pub position: Vec3,
    /// Radiant intensity (W/sr) per RGB channel; irradiance at distance d,
    /// facing it, is intensity / d^2.
    pub intensity: Vec3,
    /// A spot light's cone; `None`: the same intensity in every direction.
    pub spot: Option<Spot>,
    /// A directional light: the way its light travels (unit), `intensity`
    /// then its irradiance (W/m^2) and `position` unused (zero). Left out of
    /// the checkpoint identity's encoding when `None`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub directional: Option<Vec3>,
}

/// A spot light's cone, with Mitsuba's smooth falloff: full intensity within
/// `beam_width` of the axis, none beyond `cutoff_angle`, linear in the angle
/// between them.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Spot {
    /// The cone's axis, unit length, pointing away from the light.
    pub direction: Vec3,
    /// Degrees, in (0, 180).
    pub cutoff_angle: f32,
    /// Degrees, in [0, cutoff_angle].
    pub beam_width: f32,
}

/// A `type` of `[[lights]]` table: its keys besides [`LIGHT_KEYS`], and how it
/// reads them.
pub(crate) struct LightType {
    pub name: &'static str,
    pub keys: &'static [&'static str],
    /// Reads its table (the keys checked).
    read: fn(&ParamTable) -> Result<PointLight>,
}

/// The keys of every light, in the order an unknown key's message lists them.
const LIGHT_KEYS: &[&str] = &["type"];

/// The light types, in the order messages list them.
pub(crate) const LIGHT_TYPES: &[LightType] = &[
    LightType {
        name: "point",
        keys: &["position", "intensity"],
        read: read_point,
    },
    LightType {
        name: "spot",
        keys: &[
            "position",
            "intensity",
            "direction",
            "cutoff_angle",
            "beam_width",
        ],
        read: read_spot,
    },
    LightType {
        name: "directional",
        keys: &["direction", "irradiance"],
        read: read_directional,
    },
];

/// The scene files' light types, in the order messages list them.
pub(crate) fn light_types() -> Vec<&'static str> {
    LIGHT_TYPES.iter().map(|light| light.name).collect()
}

/// Every key of some light type: what a light without a `type` may hold.
pub(crate) fn light_keys() -> Vec<&'static str> {
    let own = LIGHT_TYPES.iter().flat_map(|light| light.keys);
    let mut keys: Vec<&str> = Vec::new();
    for &key in LIGHT_KEYS.iter().chain(own) {
        if !keys.contains(&key) {
            keys.push(key);
        }
    }
    keys
}

impl PointLight {
    /// The `[[lights]]` table `t` of type `ty`.
    pub(crate) fn parse(t: &ParamTable, ty: &str) -> Result<PointLight> {
        let Some(light) = LIGHT_TYPES.iter().find(|light| light.name == ty) else {
            return Err(t.err(t.at("type"), unknown_name("light type", ty, &light_types())));
        };
        let keys: Vec<&str> = LIGHT_KEYS.iter().chain(light.keys).copied().collect();
        t.check_keys(&keys, Some(&format!("a {ty} light")))?;
        (light.read)(t)
    }
}

/// The required colour `key` (components >= 0).
fn required_colour(t: &ParamTable, key: &str) -> Result<Vec3> {
    if !t.table.contains_key(key) {
        return Err(t.err(t.here(), format!("missing required key `{key}`")));
    }
    colour(t, key, 0.0, check_nonneg)
}

/// The required `direction`, unit length.
fn direction(t: &ParamTable) -> Result<Vec3> {
    let direction = t.require("direction", t.vec3("direction", ok)?)?;
    if !usable_length_squared(direction.length_squared()) {
        return Err(t.err(t.at("direction"), "must not be zero"));
    }
    Ok(direction.normalize())
}

fn read_point(t: &ParamTable) -> Result<PointLight> {
    let position = t.require("position", t.vec3("position", ok)?)?;
    Ok(PointLight {
        position,
        intensity: required_colour(t, "intensity")?,
        spot: None,
        directional: None,
    })
}

fn read_spot(t: &ParamTable) -> Result<PointLight> {
    let light = read_point(t)?;
    Ok(PointLight {
        spot: Some(spot_cone(t)?),
        ..light
    })
}

fn read_directional(t: &ParamTable) -> Result<PointLight> {
    let direction = direction(t)?;
    Ok(PointLight {
        position: Vec3::ZERO,
        intensity: required_colour(t, "irradiance")?,
        spot: None,
        directional: Some(direction),
    })
}

fn spot_cone(t: &ParamTable) -> Result<Spot> {
    let direction = direction(t)?;
    let cutoff_angle = t.float("cutoff_angle", check_open_angle)?.unwrap_or(20.0);
    let beam_width = t.float("beam_width", check_nonneg)?;
    let beam_width = beam_width.unwrap_or(cutoff_angle * 3.0 / 4.0);
    if beam_width > cutoff_angle {
        return Err(t.err(
            t.at("beam_width"),
            format!(
                "must not exceed `cutoff_angle` ({}), got {}",
                fmt_num(cutoff_angle),
                fmt_num(beam_width)
            ),
        ));
    }
    Ok(Spot {
        direction,
        cutoff_angle,
        beam_width,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The manual above names every key a light reads.
    #[test]
    fn the_manual_names_every_key() {
        let manual = super::super::manual(include_str!("delta_light.rs"));
        for key in light_keys() {
            assert!(manual.contains(&format!("`{key}")), "`{key}`");
        }
    }
}
