//! Arbitrary output variables (AOVs): what each sample's camera ray finds
//! first, averaged per pixel and written beside the image, as Mitsuba 3's
//! `aov` integrator computes them (`src/integrators/aov.cpp`): the inputs of a
//! denoiser (Intel Open Image Denoise takes `albedo` and `sh_normal`) and of
//! compositing (`depth`, `position`).
//!
//! They are asked for as Mitsuba's `aovs` string, `NAME:TYPE` pairs separated
//! by commas (`dd:depth,nn:sh_normal`; a bare `TYPE` is named after its type):
//! by the command line's `--aov`, the TOML's `render.aovs` (a list of such
//! pairs), or a Mitsuba file's `<integrator type="aov">` around the integrator
//! that renders the image. Each is written as the channels `NAME.SUFFIX` of the
//! EXR (`--exr`) beside the image's `R`, `G`, `B`, with Mitsuba's suffixes:
//!
//! | type | channels | at the first surface the camera ray meets (all 0 where it escapes) |
//! |---|---|---|
//! | `albedo` | `R` `G` `B` | the material's diffuse reflectance (Mitsuba's `eval_diffuse_reflectance`): the `reflectance` of `diffuse`, the `diffuse_reflectance` of the plastics, the `base_color` of `principled` and `principledthin`, textured; for any other material the BSDF's value toward the shading normal times π, Mitsuba's default (0 for smooth metals and glass) |
//! | `depth` | `T` | the distance along the ray |
//! | `position` | `X` `Y` `Z` | the point, in world space |
//! | `uv` | `U` `V` | the texture coordinates (only in scenes with textures, whose meshes' coordinates are packed) |
//! | `geo_normal` | `X` `Y` `Z` | the geometric normal on the shape's outward side (not turned toward the camera) |
//! | `sh_normal` | `X` `Y` `Z` | the shading normal (interpolated on smooth meshes, then bump- or normal-mapped), outward |
//!
//! Each pixel's AOVs average as many camera rays as its image has samples
//! (its mean count in an adaptive run), drawn from the pixel filter as the
//! image's are, so their expected values are the filter's weighted means as
//! Mitsuba's film makes them. They are traced in a pass of their own after the
//! image (Mitsuba's `aov` integrator renders its AOVs in a pass of their own
//! too), which costs about one ray per sample. The first surface is the first
//! one, masked or not; a `blend` material's albedo is one of its two by its
//! weight, in expectation Mitsuba's blend of both.
//!
//! Mitsuba's other types (`dp_du`, `dp_dv`, `duv_dx`, `duv_dy`,
//! `prim_index`, `shape_index`) are refused by name.

use serde::Serialize;

/// A type of AOV, in the order the kernel lays their sums out.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
pub enum AovKind {
    Albedo,
    Depth,
    Position,
    Uv,
    GeoNormal,
    ShNormal,
}

/// Mitsuba's AOV types that pathmix does not compute.
const UNSUPPORTED: &[&str] = &[
    "dp_du",
    "dp_dv",
    "duv_dx",
    "duv_dy",
    "prim_index",
    "shape_index",
];

impl AovKind {
    pub const ALL: [AovKind; 6] = [
        AovKind::Albedo,
        AovKind::Depth,
        AovKind::Position,
        AovKind::Uv,
        AovKind::GeoNormal,
        AovKind::ShNormal,
    ];

    /// Its type's name, as Mitsuba's `aovs` string names it.
    pub fn name(self) -> &'static str {
        match self {
            AovKind::Albedo => "albedo",
            AovKind::Depth => "depth",
            AovKind::Position => "position",
            AovKind::Uv => "uv",
            AovKind::GeoNormal => "geo_normal",
            AovKind::ShNormal => "sh_normal",
        }
    }

    pub fn from_name(name: &str) -> Option<AovKind> {
        AovKind::ALL.into_iter().find(|kind| kind.name() == name)
    }

    /// Its channels' suffixes, Mitsuba's: as many as it has values (at most 3).
    pub fn suffixes(self) -> &'static [&'static str] {
        match self {
            AovKind::Albedo => &["R", "G", "B"],
            AovKind::Depth => &["T"],
            AovKind::Position | AovKind::GeoNormal | AovKind::ShNormal => &["X", "Y", "Z"],
            AovKind::Uv => &["U", "V"],
        }
    }

    /// The kernel flag under which it is computed (`shaders/aov.wgsl`).
    pub fn flag(self) -> String {
        format!("AOV_{}", self.name().to_uppercase())
    }
}

/// One AOV asked for: the name its channels take and its type.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Aov {
    pub name: String,
    pub kind: AovKind,
}

impl Aov {
    /// Its EXR channels, `NAME.SUFFIX`, in order.
    pub fn channels(&self) -> impl Iterator<Item = String> + '_ {
        self.kind
            .suffixes()
            .iter()
            .map(|suffix| format!("{}.{suffix}", self.name))
    }

    /// As Mitsuba's `aovs` string writes it: `NAME:TYPE`.
    pub fn spec(&self) -> String {
        format!("{}:{}", self.name, self.kind.name())
    }
}

/// The AOVs of a Mitsuba `aovs` string: `NAME:TYPE` or `TYPE` items separated
/// by commas or spaces (Mitsuba's `string::tokenize`). Refused, with a
/// message: an unknown or unsupported type, an empty name or type, and a name
/// given twice (its channels would collide).
pub fn parse_aovs(spec: &str) -> Result<Vec<Aov>, String> {
    let mut aovs: Vec<Aov> = Vec::new();
    for item in spec.split([',', ' ']).filter(|item| !item.is_empty()) {
        aovs.push(parse_aov(item)?);
    }
    check_names(&aovs)?;
    Ok(aovs)
}

/// One `NAME:TYPE` or `TYPE`.
pub fn parse_aov(item: &str) -> Result<Aov, String> {
    let (name, ty) = match item.split_once(':') {
        Some((name, ty)) => (name, ty),
        None => (item, item),
    };
    if name.is_empty() || ty.is_empty() || ty.contains(':') {
        return Err(format!(
            "AOV `{item}`: expected NAME:TYPE or TYPE (as Mitsuba's `dd:depth`)"
        ));
    }
    match AovKind::from_name(ty) {
        Some(kind) => Ok(Aov {
            name: name.to_string(),
            kind,
        }),
        None => {
            let known: Vec<&str> = AovKind::ALL.iter().map(|k| k.name()).collect();
            let why = match UNSUPPORTED.contains(&ty) {
                true => "is Mitsuba's, not computed by pathmix",
                false => "is not a type of AOV",
            };
            Err(format!(
                "AOV `{item}`: `{ty}` {why} (types: {})",
                known.join(", ")
            ))
        }
    }
}

/// Each name once: two AOVs of one name would write the same channels.
pub fn check_names(aovs: &[Aov]) -> Result<(), String> {
    for (i, aov) in aovs.iter().enumerate() {
        if aovs[..i].iter().any(|other| other.name == aov.name) {
            return Err(format!("AOV name `{}` is given twice", aov.name));
        }
    }
    Ok(())
}

/// The distinct types of `aovs`, in the kernel's order (`AovKind`'s).
pub fn aov_kinds(aovs: &[Aov]) -> Vec<AovKind> {
    let mut kinds: Vec<AovKind> = aovs.iter().map(|aov| aov.kind).collect();
    kinds.sort();
    kinds.dedup();
    kinds
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_mitsubas_pairs_and_bare_types() {
        let aovs = parse_aovs("dd.y:depth, nn:sh_normal,albedo").unwrap();
        let specs: Vec<String> = aovs.iter().map(Aov::spec).collect();
        assert_eq!(specs, ["dd.y:depth", "nn:sh_normal", "albedo:albedo"]);
        let channels: Vec<String> = aovs.iter().flat_map(|a| a.channels()).collect();
        assert_eq!(
            channels,
            [
                "dd.y.T", "nn.X", "nn.Y", "nn.Z", "albedo.R", "albedo.G", "albedo.B"
            ]
        );
        assert_eq!(
            aov_kinds(&aovs),
            [AovKind::Albedo, AovKind::Depth, AovKind::ShNormal]
        );
    }

    #[test]
    fn refuses_unknown_types_empty_parts_and_repeated_names() {
        let e = parse_aovs("p:prim_index").unwrap_err();
        assert!(e.contains("Mitsuba's, not computed by pathmix"), "{e}");
        let e = parse_aovs("x:colour").unwrap_err();
        assert!(
            e.contains("not a type of AOV") && e.contains("geo_normal"),
            "{e}"
        );
        for bad in [":depth", "d:", "a:b:depth"] {
            assert!(parse_aovs(bad).is_err(), "{bad}");
        }
        let e = parse_aovs("d:depth,d:albedo").unwrap_err();
        assert_eq!(e, "AOV name `d` is given twice");
        // The same type under two names is two AOVs of one kernel value.
        let aovs = parse_aovs("a:depth,b:depth").unwrap();
        assert_eq!(aov_kinds(&aovs), [AovKind::Depth]);
    }
}
