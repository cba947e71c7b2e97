//! Where an object sits: its transform keys (`scale`, `rotate_y` or `rotate`,
//! `translate`, or `matrix`), read into an object-to-world [`Transform`] that
//! each shape kind applies to its own geometry.

use super::params::{ParamTable, Result, fmt_num, ok};
use glam::{DMat3, DVec3, Vec3};
use toml::Value;

/// The keys of an object's transform.
pub(crate) const TRANSFORM_KEYS: &[&str] = &["scale", "rotate_y", "rotate", "translate", "matrix"];

/// Mitsuba's `coordinate_system`: two unit vectors across the unit vector `n`,
/// `(s, t)` with `s x t = n` (Duff et al. 2017, "Building an Orthonormal Basis,
/// Revisited"), with drjit's sign of zero, +1.
pub(crate) fn coordinate_system(n: DVec3) -> (DVec3, DVec3) {
    let sign = if n.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        DVec3::new(n.x * n.x * a * sign + 1.0, b * sign, -n.x * sign),
        DVec3::new(b, n.y * n.y * a + sign, -n.y),
    )
}

/// Object to world: `linear` (scale, then rotation) then `translate`, in f64 so
/// that composing and applying it rounds once, to f32, at the end.
pub(crate) struct Transform {
    linear: DMat3,
    translate: DVec3,
}

/// `sin` and `cos` of `degrees`, exact at multiples of 90 degrees so axis-aligned
/// geometry stays exact.
pub(crate) fn sin_cos_degrees(degrees: f64) -> (f64, f64) {
    match degrees.rem_euclid(360.0) {
        0.0 => (0.0, 1.0),
        90.0 => (1.0, 0.0),
        180.0 => (0.0, -1.0),
        270.0 => (-1.0, 0.0),
        r => r.to_radians().sin_cos(),
    }
}

/// `matrix` (16 numbers, row-major, affine): its linear part and translation.
/// `others` are the keys it replaces, refused alongside it.
pub(crate) fn matrix(t: &ParamTable, others: &[&str]) -> Result<(DMat3, DVec3)> {
    if let Some(other) = others.iter().find(|k| t.table.contains_key(**k)) {
        return Err(t.err(
            t.at(other),
            "cannot be combined with `matrix` (the matrix is the whole transform)",
        ));
    }
    let m: [f32; 16] = t.numbers("matrix")?;
    if m[12..] != [0.0, 0.0, 0.0, 1.0] {
        return Err(t.err(
            t.at("matrix"),
            format!(
                "must be affine: its last row must be [0, 0, 0, 1], got [{}]",
                m[12..]
                    .iter()
                    .map(|&x| fmt_num(x))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        ));
    }
    let m = m.map(f64::from);
    let linear = DMat3::from_cols(
        DVec3::new(m[0], m[4], m[8]),
        DVec3::new(m[1], m[5], m[9]),
        DVec3::new(m[2], m[6], m[10]),
    );
    Ok((linear, DVec3::new(m[3], m[7], m[11])))
}

/// `rotate_y` (the book's) or `rotate = { axis, angle }`; the identity without either.
pub(crate) fn rotation(t: &ParamTable) -> Result<DMat3> {
    Ok(match (t.table.contains_key("rotate_y"), t.sub("rotate")?) {
        (true, Some(_)) => {
            return Err(t.err(
                t.at("rotate"),
                "give either `rotate_y` or `rotate`, not both",
            ));
        }
        (_, Some(r)) => {
            r.check_keys(&["axis", "angle"], Some("a rotation"))?;
            let axis = r.require("axis", r.vec3("axis", ok)?)?.as_dvec3();
            let angle = f64::from(r.require("angle", r.float("angle", ok)?)?);
            if axis.length_squared() == 0.0 {
                return Err(r.err(r.at("axis"), "must not be the zero vector"));
            }
            let (sin, cos) = sin_cos_degrees(angle);
            // Rodrigues' formula, with the exact sine and cosine.
            let k = axis.normalize();
            let cross = DMat3::from_cols(
                DVec3::new(0.0, k.z, -k.y),
                DVec3::new(-k.z, 0.0, k.x),
                DVec3::new(k.y, -k.x, 0.0),
            );
            DMat3::IDENTITY * cos
                + cross * sin
                + DMat3::from_cols(k * k.x, k * k.y, k * k.z) * (1.0 - cos)
        }
        (_, None) => {
            let (sin, cos) = sin_cos_degrees(t.float("rotate_y", ok)?.unwrap_or(0.0).into());
            // The book's rotate_y: (x, z) maps to (cos x + sin z, -sin x + cos z).
            DMat3::from_cols(
                DVec3::new(cos, 0.0, -sin),
                DVec3::Y,
                DVec3::new(sin, 0.0, cos),
            )
        }
    })
}

impl Transform {
    /// The object's transform keys: `scale`, `rotate_y` or `rotate`, `translate`,
    /// or `matrix` instead of all three.
    pub(crate) fn parse(t: &ParamTable) -> Result<Transform> {
        if t.table.contains_key("matrix") {
            let (linear, translate) = matrix(t, &["scale", "rotate_y", "rotate", "translate"])?;
            return Transform::checked(t, "matrix", linear, translate);
        }
        let scale = match t.table.get("scale") {
            None => DVec3::ONE,
            Some(Value::Array(_)) => t.require("scale", t.vec3("scale", ok)?)?.as_dvec3(),
            Some(_) => DVec3::splat(t.require("scale", t.float("scale", ok)?)?.into()),
        };
        let rotation = rotation(t)?;
        let translate = t.vec3("translate", ok)?.unwrap_or(Vec3::ZERO).as_dvec3();
        let linear = rotation * DMat3::from_diagonal(scale);
        Transform::checked(t, "scale", linear, translate)
    }

    fn checked(t: &ParamTable, key: &str, linear: DMat3, translate: DVec3) -> Result<Transform> {
        if !linear.is_finite() || !translate.is_finite() || linear.determinant() == 0.0 {
            return Err(t.err(
                t.at(key),
                "the transform is singular: it flattens the object",
            ));
        }
        Ok(Transform { linear, translate })
    }

    pub(crate) fn point(&self, p: DVec3) -> Vec3 {
        (self.linear * p + self.translate).as_vec3()
    }

    /// The object-to-world matrix's three rows, `[linear | translate]`, in f32.
    pub(crate) fn rows(&self) -> [[f32; 4]; 3] {
        std::array::from_fn(|r| {
            let row = self.linear.row(r);
            [row.x, row.y, row.z, self.translate[r]].map(|x| x as f32)
        })
    }

    pub(crate) fn vector(&self, v: DVec3) -> Vec3 {
        (self.linear * v).as_vec3()
    }

    /// The factor of a transform that scales every direction alike (a rotation
    /// times a uniform scale, maybe mirrored), or `None`.
    pub(crate) fn uniform_scale(&self) -> Option<f64> {
        let columns = [self.linear.x_axis, self.linear.y_axis, self.linear.z_axis];
        let lengths = columns.map(DVec3::length);
        let tolerance = 1e-6 * lengths[0];
        let orthogonal =
            (0..3).all(|i| columns[i].dot(columns[(i + 1) % 3]).abs() <= tolerance * lengths[0]);
        let equal = lengths.iter().all(|&l| (l - lengths[0]).abs() <= tolerance);
        (orthogonal && equal).then_some(lengths[0])
    }

    /// The factor by which the transform scales every direction across `axis`
    /// alike while keeping them across the transformed axis (a circle about
    /// the axis stays a circle about its image, as a cylinder needs), or
    /// `None` (a shear, or a scale that differs across the axis).
    pub(crate) fn across(&self, axis: DVec3) -> Option<f64> {
        let axis = axis.normalize();
        let first = axis.any_orthonormal_vector();
        let [x, y, z] = [first, axis.cross(first), axis].map(|v| self.linear * v);
        let r = x.length();
        let tolerance = 1e-6 * r;
        let circular = (y.length() - r).abs() <= tolerance
            && x.dot(y).abs() <= tolerance * r
            && x.dot(z).abs() <= tolerance * z.length()
            && y.dot(z).abs() <= tolerance * z.length();
        circular.then_some(r)
    }

    /// Whether the transform mirrors (turns counter-clockwise windings clockwise).
    pub(crate) fn mirrors(&self) -> bool {
        self.linear.determinant() < 0.0
    }

    /// A surface normal carried to world space (by the inverse transpose, so it
    /// stays perpendicular under a non-uniform scale), unit length; zero where
    /// the file's normal is zero or not finite.
    pub(crate) fn normal(&self, n: Vec3) -> Vec3 {
        let world = self.linear.inverse().transpose() * n.as_dvec3();
        world.normalize_or_zero().as_vec3()
    }
}
