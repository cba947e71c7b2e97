//! Spectra in Mitsuba 3 scenes, reduced to the RGB that Mitsuba 3's RGB variants
//! (`scalar_rgb`, `llvm_ad_rgb`) reduce them to when they load a scene: pathmix
//! renders RGB, and a scene written for Mitsuba should look as it does there.
//!
//! Mitsuba integrates a sampled spectrum against the CIE 1931 colour matching
//! functions at 1000 wavelengths from 360 to 830 nm and turns the XYZ into linear
//! sRGB (`spectrum_list_to_srgb`, src/core/spectrum.cpp); under which illuminant,
//! and how it clamps, depends on what the spectrum is for ([`Role`]). The tables
//! here are Mitsuba's (include/mitsuba/core/spectrum.h, src/core/spectrum.cpp) in
//! its 32-bit floats and the arithmetic is its double-precision path, so the
//! colours agree with the ones Mitsuba renders with to a 32-bit float's rounding.

use std::path::Path;

/// What a spectrum is read for: Mitsuba's RGB variants reduce each differently
/// (`Properties::get_texture_impl`, src/core/properties.cpp).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// A BSDF's or texture's colour (`get_texture`): the light it reflects of
    /// D65, sRGB's white, so that a flat reflectance is about that grey (0.5 is
    /// 0.4995); clamped to [0, 1].
    Reflectance,
    /// A conductor's `eta` or `k` (`get_unbounded_texture`): weighted by D65
    /// as a reflectance is, only negatives clamped (to 0).
    Unbounded,
    /// An emitter's radiance or intensity (`get_emissive_texture`): the light
    /// itself, unweighted, so that a flat spectrum is the equal-energy white, a
    /// purplish colour in sRGB; only negatives clamped.
    Emission,
}

/// A spectrum as a Mitsuba scene writes one (Mitsuba's `Properties::Spectrum`).
#[derive(Clone, Debug, PartialEq)]
pub enum Spectrum {
    /// The same value at every wavelength: `value="0.5"`.
    Uniform(f64),
    /// Values at increasing wavelengths (nanometres), linear between them and
    /// zero outside them.
    Sampled {
        wavelengths: Vec<f64>,
        values: Vec<f64>,
    },
}

/// The largest `.spd` file read: Mitsuba's own measured data are a few
/// kilobytes, and a scene's file far past this is not a spectrum.
pub const MAX_SPD_BYTES: u64 = 1 << 20;

impl Spectrum {
    /// A `<spectrum value="...">`: one number, or `wavelength:value` pairs
    /// separated by commas or spaces, as Mitsuba's `Properties::Spectrum` reads it.
    pub fn parse(text: &str) -> Result<Spectrum, String> {
        let tokens = tokens(text);
        if let [single] = tokens[..] {
            if !single.contains(':') {
                return number(single).map(Spectrum::Uniform);
            }
        }
        let mut wavelengths = Vec::with_capacity(tokens.len());
        let mut values = Vec::with_capacity(tokens.len());
        for token in tokens {
            let Some((wavelength, value)) = token.split_once(':') else {
                return Err(format!(
                    "`{}` is not a wavelength:value pair (a spectrum is one number or \
                     such pairs, as `400:0.3, 700:0.6`)",
                    super::excerpt(token)
                ));
            };
            wavelengths.push(number(wavelength)?);
            values.push(number(value)?);
        }
        Spectrum::sampled(wavelengths, values)
    }

    /// Values at the given wavelengths: at least two, the wavelengths increasing.
    pub fn sampled(wavelengths: Vec<f64>, values: Vec<f64>) -> Result<Spectrum, String> {
        if wavelengths.len() != values.len() {
            return Err(format!(
                "{} wavelengths but {} values",
                wavelengths.len(),
                values.len()
            ));
        }
        if wavelengths.len() < 2 {
            return Err(format!(
                "a sampled spectrum needs at least two wavelengths, got {}",
                wavelengths.len()
            ));
        }
        if let Some(pair) = wavelengths.windows(2).find(|pair| pair[1] <= pair[0]) {
            return Err(format!(
                "the wavelengths must increase, but {} follows {}",
                pair[1], pair[0]
            ));
        }
        Ok(Spectrum::Sampled {
            wavelengths,
            values,
        })
    }

    /// The `irregular` plugin's `wavelengths` and `values`, two lists of numbers.
    pub fn from_lists(wavelengths: &str, values: &str) -> Result<Spectrum, String> {
        Spectrum::sampled(numbers(wavelengths)?, numbers(values)?)
    }

    /// The `regular` plugin's `values`, evenly spaced from `min` to `max` nm.
    pub fn regular(values: &str, min: f64, max: f64) -> Result<Spectrum, String> {
        let values = numbers(values)?;
        if values.len() < 2 {
            return Err(format!(
                "a regular spectrum needs at least two values, got {}",
                values.len()
            ));
        }
        let step = (max - min) / (values.len() - 1) as f64;
        let wavelengths = (0..values.len()).map(|i| min + step * i as f64).collect();
        Spectrum::sampled(wavelengths, values)
    }

    /// An `.spd` file's text: a wavelength and a value on each line, separated by
    /// white space; `#` starts a comment, blank lines are skipped.
    pub fn parse_spd(text: &str) -> Result<Spectrum, String> {
        let mut wavelengths = Vec::new();
        let mut values = Vec::new();
        for (index, line) in text.lines().enumerate() {
            let data = line.split_once('#').map_or(line, |(data, _)| data);
            let fields: Vec<&str> = data.split_whitespace().collect();
            let at_line = |message: String| format!("line {}: {message}", index + 1);
            match fields[..] {
                [] => continue,
                [wavelength, value] => {
                    wavelengths.push(number(wavelength).map_err(at_line)?);
                    values.push(number(value).map_err(at_line)?);
                }
                _ => {
                    return Err(at_line(format!(
                        "expected a wavelength and a value, got `{}`",
                        super::excerpt(data.trim())
                    )));
                }
            }
        }
        Spectrum::sampled(wavelengths, values)
    }

    /// The `.spd` file at `path`, at most [`MAX_SPD_BYTES`] long. The message of
    /// an error names the file, and the line where there is one.
    pub fn read_spd(path: &Path) -> Result<Spectrum, String> {
        let shown = path.display();
        let bytes = crate::paths::read_input_prefix(path, MAX_SPD_BYTES + 1)
            .map_err(|e| format!("cannot read the spectrum file `{shown}`: {e}"))?;
        if bytes.len() as u64 > MAX_SPD_BYTES {
            return Err(format!(
                "the spectrum file `{shown}` is longer than {MAX_SPD_BYTES} bytes (is it a \
                 spectrum?)"
            ));
        }
        let text = String::from_utf8(bytes)
            .map_err(|_| format!("the spectrum file `{shown}` is not UTF-8 text"))?;
        Spectrum::parse_spd(&text).map_err(|e| format!("in the spectrum file `{shown}`, {e}"))
    }

    /// The linear sRGB colour Mitsuba's RGB variants use for this spectrum when it
    /// is read for `role`.
    pub fn rgb(&self, role: Role) -> [f64; 3] {
        match self {
            // A uniform reflectance stays Mitsuba's `uniform` plugin, unclamped.
            Spectrum::Uniform(value) if role != Role::Emission => [*value; 3],
            // The equal-energy spectrum, `xyz_to_srgb(1, 1, 1)`, in Mitsuba's
            // normalisation (a unit spectrum has luminance 1): the row sums.
            Spectrum::Uniform(value) => {
                XYZ_TO_SRGB.map(|row| value * row.map(f64::from).iter().sum::<f64>())
            }
            Spectrum::Sampled {
                wavelengths,
                values,
            } => integrate(role, |w| {
                let (first, last) = (wavelengths[0], wavelengths[wavelengths.len() - 1]);
                if w < first || w > last {
                    return None;
                }
                // The interval holding `w`, as Mitsuba's `find_interval`.
                let i = (wavelengths.partition_point(|&x| x <= w) - 1).min(wavelengths.len() - 2);
                let (w0, w1) = (wavelengths[i], wavelengths[i + 1]);
                let (v0, v1) = (values[i], values[i + 1]);
                Some(((w - w1) * v0 + (w0 - w) * v1) / (w0 - w1))
            }),
        }
    }
}

/// The emission of a black body at `temperature` kelvins between the
/// wavelengths `range` (nm), as Mitsuba's `blackbody` plugin gives it: in
/// W m⁻² sr⁻¹ nm⁻¹ (Planck's law, with Mitsuba's constants). Mitsuba's RGB
/// variants cannot render that plugin (it is spectral only); this is the colour
/// its spectral variants render it with, reduced as Mitsuba reduces every
/// emitted spectrum in its RGB variants ([`Role::Emission`]).
pub fn blackbody_rgb(temperature: f64, range: [f64; 2]) -> [f64; 3] {
    const SPEED_OF_LIGHT: f64 = 2.997_924_58e8;
    const PLANCK: f64 = 6.626_070_04e-34;
    const BOLTZMANN: f64 = 1.380_648_52e-23;
    const C0: f64 = 2.0 * PLANCK * SPEED_OF_LIGHT * SPEED_OF_LIGHT;
    const C1: f64 = PLANCK * SPEED_OF_LIGHT / BOLTZMANN;
    integrate(Role::Emission, |w| {
        if w < range[0] || w > range[1] {
            return None;
        }
        let lambda = w * 1e-9;
        // Per nanometre, not per metre.
        Some(1e-9 * C0 / (lambda.powi(5) * ((C1 / (lambda * temperature)).exp() - 1.0)))
    })
}

/// The conductor presets (`material` of `conductor` and `roughconductor`) that
/// Mitsuba 3 reads from its data folder (`data/ior/NAME.eta.spd` and `.k.spd`)
/// beyond the ones its documentation lists, which are the TOML format's
/// `NAMED_CONDUCTORS` (src/scene/parse.rs): name, RGB `eta`, RGB `k`, as Mitsuba's
/// RGB variants reduce the measured spectra (under no illuminant, negatives
/// clamped to 0). Read back from Mitsuba by `scripts/conductor-presets.py
/// --unlisted`, which prints these rows.
// One row per line, as the script prints them.
#[rustfmt::skip]
pub const UNLISTED_CONDUCTORS: &[(&str, [f32; 3], [f32; 3])] = &[
    // Mitsuba 3.9.1, variant scalar_rgb: (name, eta, k)
    ("AlAs_palik", [3.605296, 3.2329378, 2.2163186], [0.0006794373, 0.0, 0.007512709]),
    ("AlSb_palik", [0.0, 4.1393747, 4.6692543], [0.0, 0.09400908, 1.30057]),
    ("Be_palik", [4.1850123, 3.1850293, 2.7840612], [3.835466, 3.0101223, 2.868994]),
    ("CsI_palik", [2.1448996, 1.7023189, 1.6624272], [0.0, 0.0, 0.0]),
    ("Cu2O_palik", [3.5517726, 2.9498696, 2.7518754], [0.11420702, 0.19389686, 0.6061339]),
    ("CuO_palik", [3.247541, 2.4478052, 2.2102196], [0.52108955, 0.57003075, 0.72217894]),
    ("Cu_palik", [0.21322851, 0.9197154, 1.1024108], [3.9218733, 2.4573317, 2.136584]),
    ("HgTe_palik", [4.77904, 3.2311962, 2.6599011], [1.6316127, 1.5808104, 1.7292874]),
    ("Hg_palik", [2.3989387, 1.440028, 0.9095704], [6.327587, 4.371925, 3.4217637]),
    ("Ir_palik", [3.0863, 2.0821905, 1.6179146], [5.592153, 4.067088, 3.267312]),
    ("K_palik", [0.06404319, 0.046409767, 0.038184915], [2.1041996, 1.34894, 0.9131259]),
    ("Li_palik", [0.26579094, 0.19561832, 0.22094862], [3.540155, 2.3111234, 1.6686072]),
    ("MgO_palik", [2.0895839, 1.6507235, 1.594879], [4.3326952e-12, 0.0, 2.4986457e-11]),
    ("Mo_palik", [4.483974, 3.5251307, 2.7763104], [4.1114373, 3.420827, 3.1506073]),
    ("Nb_palik", [3.420074, 2.7900932, 2.3956294], [3.4413946, 2.7376661, 2.5797458]),
    ("Rh_palik", [2.5857935, 1.8602164, 1.5542634], [6.7822604, 4.702987, 3.976073]),
    ("Se-e", [5.722849, 4.165736, 4.0813384], [0.8711363, 1.1051575, 1.5653203]),
    ("Se-e_palik", [5.722849, 4.165736, 4.0813384], [0.8711363, 1.1051575, 1.5653203]),
    ("Se_palik", [4.0583115, 2.842935, 2.8208535], [0.75404954, 0.6384435, 0.52180755]),
    ("SiC_palik", [3.1723416, 2.5259717, 2.4793706], [7.5376636e-07, 0.0, 1.0192531e-05]),
    ("SnTe_palik", [4.5242496, 1.981645, 1.2815913], [0.0, 0.0, 0.0]),
    ("Ta_palik", [2.062721, 2.3929389, 2.6279287], [2.4083598, 1.7414864, 1.9470278]),
    ("Te-e", [7.508907, 4.2964287, 2.3699877], [5.5839286, 4.947205, 3.9975922]),
    ("Te-e_palik", [7.508907, 4.2964287, 2.3699877], [5.5839286, 4.947205, 3.9975922]),
    ("Te_palik", [7.3902335, 4.482105, 2.637106], [3.2560222, 3.5270588, 3.2920542]),
    ("ThF4_palik", [1.8307136, 1.4422286, 1.3876476], [0.0, 0.0, 0.0]),
    ("TiC_palik", [3.7005284, 2.8374221, 2.582287], [3.265635, 2.3515892, 2.1727905]),
    ("TiN_palik", [1.6484497, 1.150516, 1.3798234], [3.368328, 1.9434981, 1.1020677]),
    ("TiO2-e", [3.1065645, 2.5131683, 2.5824444], [2.9751605e-05, 0.0, 0.00018269809]),
    ("TiO2-e_palik", [3.1065645, 2.5131683, 2.5824444], [2.9751605e-05, 0.0, 0.00018269809]),
    ("TiO2_palik", [3.45661, 2.8017359, 2.905175], [0.00010526484, 0.0, 0.0006528865]),
    ("VC_palik", [3.657566, 2.752736, 2.532672], [3.0683007, 2.1986873, 1.9631927]),
    ("VN_palik", [2.8656023, 2.119189, 1.9400911], [3.0322425, 2.0561156, 1.6163063]),
    ("d-C_palik", [2.7087197, 2.3188257, 2.2288976], [0.0, 0.0, 0.0]),
];

/// Splits at commas and white space, as Mitsuba's `tokenize` (XML has already
/// turned line breaks and tabs in attributes into spaces).
fn tokens(text: &str) -> Vec<&str> {
    text.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|s| !s.is_empty())
        .collect()
}

fn number(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(format!(
            "`{}` is not a finite number",
            super::excerpt(text.trim())
        )),
    }
}

fn numbers(text: &str) -> Result<Vec<f64>, String> {
    tokens(text).into_iter().map(number).collect()
}

// ---------------------------------------------------------------------------------
// Mitsuba's integration (src/core/spectrum.cpp, include/mitsuba/core/spectrum.h)

const CIE_MIN: f64 = 360.0;
const CIE_MAX: f64 = 830.0;
const CIE_SAMPLES: usize = 95;
/// Scales the CIE curves so that a unit spectrum has luminance 1.
const CIE_Y_NORMALIZATION: f64 = 1.0 / 106.750_259_399_414_06;
/// Scales the D65 table so that D65 has luminance 1.
const CIE_D65_NORMALIZATION: f64 = 1.0 / 98.997_417_518_762_55;
/// The wavelengths `spectrum_list_to_srgb` sums over.
const INTEGRATION_STEPS: u32 = 1000;

/// Mitsuba's `spectrum_list_to_srgb` of the spectrum `value_at` (`None`
/// outside its wavelengths), with its `bounded` and `d65` set as `role` sets them.
fn integrate(role: Role, value_at: impl Fn(f64) -> Option<f64>) -> [f64; 3] {
    let mut xyz = [0.0f64; 3];
    for i in 0..INTEGRATION_STEPS {
        let w = CIE_MIN + (f64::from(i) / f64::from(INTEGRATION_STEPS - 1)) * (CIE_MAX - CIE_MIN);
        let Some(value) = value_at(w) else {
            continue;
        };
        let illuminant = match role {
            Role::Reflectance | Role::Unbounded => table_at(&D65, w) * CIE_D65_NORMALIZATION,
            Role::Emission => 1.0,
        };
        for (sum, curve) in xyz.iter_mut().zip(&CIE1931_XYZ) {
            *sum += table_at(curve, w) * value * illuminant;
        }
    }
    let scale = (CIE_MAX - CIE_MIN) * CIE_Y_NORMALIZATION / f64::from(INTEGRATION_STEPS);
    let xyz = xyz.map(|x| x * scale);
    let rgb = XYZ_TO_SRGB.map(|row| {
        row.iter()
            .zip(xyz)
            .map(|(&m, x)| f64::from(m) * x)
            .sum::<f64>()
    });
    match role {
        Role::Reflectance => rgb.map(|c| c.clamp(0.0, 1.0)),
        Role::Unbounded | Role::Emission => rgb.map(|c| c.max(0.0)),
    }
}

/// A table over `CIE_MIN..=CIE_MAX`, linear between its entries (Mitsuba's
/// `cie1931_xyz` and `cie_d65`).
fn table_at(table: &[f32; CIE_SAMPLES], w: f64) -> f64 {
    let t = (w - CIE_MIN) * ((CIE_SAMPLES - 1) as f64 / (CIE_MAX - CIE_MIN));
    let i = (t as usize).min(CIE_SAMPLES - 2);
    let w1 = t - i as f64;
    (1.0 - w1).mul_add(f64::from(table[i]), w1 * f64::from(table[i + 1]))
}

/// Mitsuba's `xyz_to_srgb`: CIE XYZ to linear sRGB (Rec. 709 primaries, D65 white).
const XYZ_TO_SRGB: [[f32; 3]; 3] = [
    [3.240479, -1.53715, -0.498535],
    [-0.969256, 1.875991, 0.041556],
    [0.055648, -0.204043, 1.057311],
];

/// The CIE 1931 2° colour matching functions x̄, ȳ, z̄ from 360 to 830 nm in 5 nm
/// steps, as Mitsuba holds them (`cie1931_tbl`).
#[rustfmt::skip]
const CIE1931_XYZ: [[f32; CIE_SAMPLES]; 3] = [
    [
        0.0001299, 0.0002321, 0.0004149, 0.0007416, 0.001368, 0.002236, 0.004243, 0.00765,
        0.01431, 0.02319, 0.04351, 0.07763, 0.13438, 0.21477, 0.2839, 0.3285,
        0.34828, 0.34806, 0.3362, 0.3187, 0.2908, 0.2511, 0.19536, 0.1421,
        0.09564, 0.05795001, 0.03201, 0.0147, 0.0049, 0.0024, 0.0093, 0.0291,
        0.06327, 0.1096, 0.1655, 0.2257499, 0.2904, 0.3597, 0.4334499, 0.5120501,
        0.5945, 0.6784, 0.7621, 0.8425, 0.9163, 0.9786, 1.0263, 1.0567,
        1.0622, 1.0456, 1.0026, 0.9384, 0.8544499, 0.7514, 0.6424, 0.5419,
        0.4479, 0.3608, 0.2835, 0.2187, 0.1649, 0.1212, 0.0874, 0.0636,
        0.04677, 0.0329, 0.0227, 0.01584, 0.01135916, 0.008110916, 0.005790346, 0.004109457,
        0.002899327, 0.00204919, 0.001439971, 0.0009999493, 0.0006900786, 0.0004760213, 0.0003323011, 0.0002348261,
        0.0001661505, 0.000117413, 0.00008307527, 0.00005870652, 0.00004150994, 0.00002935326, 0.00002067383, 0.00001455977,
        0.00001025398, 0.000007221456, 0.000005085868, 0.000003581652, 0.000002522525, 0.000001776509, 0.000001251141,
    ],
    [
        0.000003917, 0.000006965, 0.00001239, 0.00002202, 0.000039, 0.000064, 0.00012, 0.000217,
        0.000396, 0.00064, 0.00121, 0.00218, 0.004, 0.0073, 0.0116, 0.01684,
        0.023, 0.0298, 0.038, 0.048, 0.06, 0.0739, 0.09098, 0.1126,
        0.13902, 0.1693, 0.20802, 0.2586, 0.323, 0.4073, 0.503, 0.6082,
        0.71, 0.7932, 0.862, 0.9148501, 0.954, 0.9803, 0.9949501, 1.0,
        0.995, 0.9786, 0.952, 0.9154, 0.87, 0.8163, 0.757, 0.6949,
        0.631, 0.5668, 0.503, 0.4412, 0.381, 0.321, 0.265, 0.217,
        0.175, 0.1382, 0.107, 0.0816, 0.061, 0.04458, 0.032, 0.0232,
        0.017, 0.01192, 0.00821, 0.005723, 0.004102, 0.002929, 0.002091, 0.001484,
        0.001047, 0.00074, 0.00052, 0.0003611, 0.0002492, 0.0001719, 0.00012, 0.0000848,
        0.00006, 0.0000424, 0.00003, 0.0000212, 0.00001499, 0.0000106, 0.0000074657, 0.0000052578,
        0.0000037029, 0.0000026078, 0.0000018366, 0.0000012934, 0.00000091093, 0.00000064153, 0.00000045181,
    ],
    [
        0.0006061, 0.001086, 0.001946, 0.003486, 0.006450001, 0.01054999, 0.02005001, 0.03621,
        0.06785001, 0.1102, 0.2074, 0.3713, 0.6456, 1.0390501, 1.3856, 1.62296,
        1.74706, 1.7826, 1.77211, 1.7441, 1.6692, 1.5281, 1.28764, 1.0419,
        0.8129501, 0.6162, 0.46518, 0.3533, 0.272, 0.2123, 0.1582, 0.1117,
        0.07824999, 0.05725001, 0.04216, 0.02984, 0.0203, 0.0134, 0.008749999, 0.005749999,
        0.0039, 0.002749999, 0.0021, 0.0018, 0.001650001, 0.0014, 0.0011, 0.001,
        0.0008, 0.0006, 0.00034, 0.00024, 0.00019, 0.0001, 0.00004999999, 0.00003,
        0.00002, 0.00001, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
        0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
        0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
        0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
        0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    ],
];

/// The CIE D65 illuminant from 360 to 830 nm in 5 nm steps, relative to its power
/// at 560 nm, as Mitsuba holds it (`d65_table`).
#[rustfmt::skip]
const D65: [f32; CIE_SAMPLES] = [
    46.6383, 49.3637, 52.0891, 51.0323, 49.9755, 52.3118, 54.6482, 68.7015,
    82.7549, 87.1204, 91.486, 92.4589, 93.4318, 90.057, 86.6823, 95.7736,
    104.865, 110.936, 117.008, 117.41, 117.812, 116.336, 114.861, 115.392,
    115.923, 112.367, 108.811, 109.082, 109.354, 108.578, 107.802, 106.296,
    104.79, 106.239, 107.689, 106.047, 104.405, 104.225, 104.046, 102.023,
    100.0, 98.1671, 96.3342, 96.0611, 95.788, 92.2368, 88.6856, 89.3459,
    90.0062, 89.8026, 89.5991, 88.6489, 87.6987, 85.4936, 83.2886, 83.4939,
    83.6992, 81.863, 80.0268, 80.1207, 80.2146, 81.2462, 82.2778, 80.281,
    78.2842, 74.0027, 69.7213, 70.6652, 71.6091, 72.979, 74.349, 67.9765,
    61.604, 65.7448, 69.8856, 72.4863, 75.087, 69.3398, 63.5927, 55.0054,
    46.4182, 56.6118, 66.8054, 65.0941, 63.3828, 63.8434, 64.304, 61.8779,
    59.4519, 55.7054, 51.959, 54.6998, 57.4406, 58.8765, 60.3125,
];

#[cfg(test)]
mod tests {
    use super::*;

    // The references are the colours Mitsuba 3.9.1's `llvm_ad_rgb` variant loads
    // each spectrum as, printed by `scripts/spectrum-references.py` (a `diffuse`
    // BSDF's `reflectance`, an `area` emitter's `radiance` or a `conductor`'s
    // `eta`, read back with `mi.traverse`) as the shortest decimals of its 32-bit
    // floats. pathmix computes in 64 bits what Mitsuba computes in 64 and stores in
    // 32, so they agree to a 32-bit float's rounding, 6e-8 relative; the
    // tolerance is 1e-6 of the colour's largest channel.
    fn assert_mitsuba(ours: [f64; 3], mitsuba: [f64; 3], what: &str) {
        let scale = mitsuba.iter().fold(0.0f64, |m, c| m.max(c.abs()));
        for (o, m) in ours.iter().zip(mitsuba) {
            assert!(
                (o - m).abs() <= 1e-6 * scale,
                "{what}: {ours:?}, Mitsuba {mitsuba:?}"
            );
        }
    }

    fn rgb(text: &str, role: Role) -> [f64; 3] {
        Spectrum::parse(text).unwrap().rgb(role)
    }

    // The reflectances of Bitterli's Cornell box (scenes-bitterli/cbox/scene.xml).
    const CBOX_WHITE: &str = "400:0.343, 404:0.445, 408:0.551, 412:0.624, 416:0.665, 420:0.687, 424:0.708, \
      428:0.723, 432:0.715, 436:0.71, 440:0.745, 444:0.758, 448:0.739, 452:0.767, \
      456:0.777, 460:0.765, 464:0.751, 468:0.745, 472:0.748, 476:0.729, 480:0.745, \
      484:0.757, 488:0.753, 492:0.75, 496:0.746, 500:0.747, 504:0.735, 508:0.732, \
      512:0.739, 516:0.734, 520:0.725, 524:0.721, 528:0.733, 532:0.725, 536:0.732, \
      540:0.743, 544:0.744, 548:0.748, 552:0.728, 556:0.716, 560:0.733, 564:0.726, \
      568:0.713, 572:0.74, 576:0.754, 580:0.764, 584:0.752, 588:0.736, 592:0.734, \
      596:0.741, 600:0.74, 604:0.732, 608:0.745, 612:0.755, 616:0.751, 620:0.744, \
      624:0.731, 628:0.733, 632:0.744, 636:0.731, 640:0.712, 644:0.708, 648:0.729, \
      652:0.73, 656:0.727, 660:0.707, 664:0.703, 668:0.729, 672:0.75, 676:0.76, \
      680:0.751, 684:0.739, 688:0.724, 692:0.73, 696:0.74, 700:0.737";
    const CBOX_RED: &str = "400:0.04, 404:0.046, 408:0.048, 412:0.053, 416:0.049, 420:0.05, 424:0.053, \
      428:0.055, 432:0.057, 436:0.056, 440:0.059, 444:0.057, 448:0.061, 452:0.061, \
      456:0.06, 460:0.062, 464:0.062, 468:0.062, 472:0.061, 476:0.062, 480:0.06, \
      484:0.059, 488:0.057, 492:0.058, 496:0.058, 500:0.058, 504:0.056, 508:0.055, \
      512:0.056, 516:0.059, 520:0.057, 524:0.055, 528:0.059, 532:0.059, 536:0.058, \
      540:0.059, 544:0.061, 548:0.061, 552:0.063, 556:0.063, 560:0.067, 564:0.068, \
      568:0.072, 572:0.08, 576:0.09, 580:0.099, 584:0.124, 588:0.154, 592:0.192, \
      596:0.255, 600:0.287, 604:0.349, 608:0.402, 612:0.443, 616:0.487, 620:0.513, \
      624:0.558, 628:0.584, 632:0.62, 636:0.606, 640:0.609, 644:0.651, 648:0.612, \
      652:0.61, 656:0.65, 660:0.638, 664:0.627, 668:0.62, 672:0.63, 676:0.628, 680:0.642, \
      684:0.639, 688:0.657, 692:0.639, 696:0.635, 700:0.642";
    const CBOX_GREEN: &str = "400:0.092, 404:0.096, 408:0.098, 412:0.097, 416:0.098, 420:0.095, 424:0.095, \
      428:0.097, 432:0.095, 436:0.094, 440:0.097, 444:0.098, 448:0.096, 452:0.101, \
      456:0.103, 460:0.104, 464:0.107, 468:0.109, 472:0.112, 476:0.115, 480:0.125, \
      484:0.14, 488:0.16, 492:0.187, 496:0.229, 500:0.285, 504:0.343, 508:0.39, \
      512:0.435, 516:0.464, 520:0.472, 524:0.476, 528:0.481, 532:0.462, 536:0.447, \
      540:0.441, 544:0.426, 548:0.406, 552:0.373, 556:0.347, 560:0.337, 564:0.314, \
      568:0.285, 572:0.277, 576:0.266, 580:0.25, 584:0.23, 588:0.207, 592:0.186, \
      596:0.171, 600:0.16, 604:0.148, 608:0.141, 612:0.136, 616:0.13, 620:0.126, \
      624:0.123, 628:0.121, 632:0.122, 636:0.119, 640:0.114, 644:0.115, 648:0.117, \
      652:0.117, 656:0.118, 660:0.12, 664:0.122, 668:0.128, 672:0.132, 676:0.139, \
      680:0.144, 684:0.146, 688:0.15, 692:0.152, 696:0.157, 700:0.159";
    /// The Cornell box's walls (reflectances, under D65) and its light (an
    /// emission, unweighted): the scene whose spectra started this.
    #[test]
    fn cornell_box_spectra_match_mitsuba() {
        let cases = [
            (CBOX_WHITE, [0.735013, 0.7356246, 0.73626435]),
            (CBOX_RED, [0.49132004, 0.049228106, 0.0509219]),
            (CBOX_GREEN, [0.06828254, 0.39776018, 0.08629087]),
        ];
        for (text, mitsuba) in cases {
            assert_mitsuba(rgb(text, Role::Reflectance), mitsuba, text);
        }
        let light = "400:0, 500:8, 600:15.6, 700:18.4";
        assert_mitsuba(
            rgb(light, Role::Emission),
            [20.710836, 10.854634, 2.771152],
            light,
        );
    }

    /// A uniform spectrum stays grey as a reflectance or a conductor's index; as
    /// an emission it is the equal-energy white, purplish in sRGB.
    #[test]
    fn uniform_spectra_match_mitsuba() {
        assert_eq!(rgb("0.5", Role::Reflectance), [0.5; 3]);
        // Given by wavelength, a flat 0.5 is Mitsuba's sum over its 1000
        // wavelengths, which is not quite its normalisation's integral.
        let flat = "360:0.5, 830:0.5";
        assert_mitsuba(
            rgb(flat, Role::Reflectance),
            [0.49949265, 0.49943686, 0.4994008],
            flat,
        );
        assert_eq!(rgb("1.7", Role::Unbounded), [1.7; 3]);
        assert_mitsuba(
            rgb("2", Role::Emission),
            [2.4095879, 1.896582, 1.8178321],
            "2",
        );
    }

    /// Colours outside sRGB's gamut are clamped as Mitsuba clamps them: a
    /// reflectance to [0, 1], an emission or a conductor's index only at 0.
    #[test]
    fn out_of_gamut_colours_clamp_as_mitsuba() {
        let narrow_green = "500:0, 520:1, 540:0";
        assert_mitsuba(
            rgb(narrow_green, Role::Reflectance),
            [0.0, 0.24629533, 0.0],
            narrow_green,
        );
        assert_mitsuba(
            rgb(narrow_green, Role::Emission),
            [0.0, 0.22927283, 0.0],
            narrow_green,
        );
        // An `eta` above 1 stays: weighted by D65 as a reflectance, not clamped at 1.
        let eta = "400:1.5, 500:0.8, 600:0.3, 700:0.2";
        assert_mitsuba(
            rgb(eta, Role::Unbounded),
            [0.17729497, 0.5709648, 1.1914738],
            eta,
        );
        assert_eq!(rgb("400:5, 700:5", Role::Reflectance), [1.0; 3]);
    }

    /// Mitsuba's RGB variants cannot render a black body; the reference is
    /// Mitsuba's `blackbody` evaluated by its `scalar_spectral` variant at the
    /// wavelengths it integrates over, read by `llvm_ad_rgb` as an emitter's
    /// samples (the script's note). Mitsuba evaluates Planck's law in 32 bits,
    /// pathmix in 64: 1e-5.
    #[test]
    fn blackbody_matches_mitsuba() {
        let cases = [
            (2700.0, [314.19116, 130.49847, 31.168295]),
            (6500.0, [43918.598, 41407.184, 43582.758]),
        ];
        for (temperature, mitsuba) in cases {
            let ours = blackbody_rgb(temperature, [CIE_MIN, CIE_MAX]);
            for (o, m) in ours.iter().zip(mitsuba) {
                assert!(
                    (o - m).abs() <= 1e-5 * m,
                    "{temperature} K: {ours:?}, Mitsuba {mitsuba:?}"
                );
            }
        }
        // Outside its wavelength range it does not emit.
        assert_eq!(blackbody_rgb(2700.0, [200.0, 300.0]), [0.0; 3]);
    }

    /// An `.spd` file: comments, blank lines, a comment after the numbers.
    #[test]
    fn spd_files_match_mitsuba() {
        let text = "# a reflectance\n400 0.1\n500 0.5\n\n600 0.9 # the peak\n700 0.3\n";
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("test.spd");
        std::fs::write(&path, text).unwrap();
        let spectrum = Spectrum::read_spd(&path).unwrap();
        assert_eq!(
            spectrum,
            Spectrum::parse("400:0.1, 500:0.5, 600:0.9, 700:0.3").unwrap()
        );
        assert_mitsuba(
            spectrum.rgb(Role::Reflectance),
            [0.8547973, 0.6875398, 0.2650152],
            "reflectance",
        );
        assert_mitsuba(
            spectrum.rgb(Role::Emission),
            [0.999234, 0.6596998, 0.22944438],
            "emission",
        );
        // Windows line ends read the same.
        let crlf = Spectrum::parse_spd(&text.replace('\n', "\r\n")).unwrap();
        assert_eq!(crlf, spectrum);
    }

    /// The `irregular` and `regular` plugins' lists are the same samples.
    #[test]
    fn plugin_lists_are_the_same_samples() {
        let pairs = Spectrum::parse("400:0.1, 550:0.5, 700:0.2").unwrap();
        assert_eq!(
            Spectrum::from_lists("400, 550, 700", "0.1 0.5 0.2").unwrap(),
            pairs
        );
        assert_eq!(
            Spectrum::regular("0.1, 0.5, 0.2", 400.0, 700.0).unwrap(),
            pairs
        );
    }

    /// Two rows against Mitsuba itself, read by hand from `llvm_ad_rgb` (`mi.traverse`
    /// of a loaded `conductor` with that `material`: `eta.value`, `k.value`), not from
    /// the script, which reads `scalar_rgb`; and the table adds names, never
    /// repeats one the TOML format knows.
    #[test]
    fn unlisted_conductors_match_mitsuba() {
        let mitsuba = [
            (
                "Se-e",
                [5.722849, 4.165736, 4.0813384],
                [0.8711363, 1.1051575, 1.5653203],
            ),
            (
                "Cu_palik",
                [0.21322851, 0.9197154, 1.1024108],
                [3.9218733, 2.4573317, 2.136584],
            ),
        ];
        for (name, eta, k) in mitsuba {
            let row = UNLISTED_CONDUCTORS.iter().find(|(n, _, _)| *n == name);
            assert_eq!(row, Some(&(name, eta, k)));
        }
        let listed = &super::super::parse::NAMED_CONDUCTORS;
        for (name, _, _) in UNLISTED_CONDUCTORS {
            assert!(listed.iter().all(|(n, _, _)| n != name), "{name}");
        }
        // Mitsuba 3.9.1's data folder holds 71 presets; 37 are listed.
        assert_eq!(UNLISTED_CONDUCTORS.len() + listed.len() - 1, 71);
    }

    #[test]
    fn malformed_spectra_are_refused() {
        let cases = [
            ("", "at least two wavelengths, got 0"),
            ("400:0.5", "at least two wavelengths, got 1"),
            ("0.5 0.6", "`0.5` is not a wavelength:value pair"),
            (
                "400:0.5, 400:0.6",
                "the wavelengths must increase, but 400 follows 400",
            ),
            (
                "500:0.5, 400:0.6",
                "the wavelengths must increase, but 400 follows 500",
            ),
            ("400:0.5, 500:x", "`x` is not a finite number"),
            ("400:0.5, 500:inf", "`inf` is not a finite number"),
            ("400:0.5:1, 500:1", "`0.5:1` is not a finite number"),
            ("nan", "`nan` is not a finite number"),
        ];
        for (text, expected) in cases {
            let e = Spectrum::parse(text).unwrap_err();
            assert!(e.contains(expected), "{text:?}: {e}");
        }
        let e = Spectrum::from_lists("400, 500, 600", "1, 2").unwrap_err();
        assert_eq!(e, "3 wavelengths but 2 values");
        let e = Spectrum::regular("1", 400.0, 700.0).unwrap_err();
        assert!(e.contains("at least two values, got 1"), "{e}");
        let e = Spectrum::regular("1, 2", 700.0, 400.0).unwrap_err();
        assert!(e.contains("must increase"), "{e}");
    }

    #[test]
    fn malformed_spd_files_are_refused() {
        let cases = [
            (
                "400 0.1\n500\n",
                "line 2: expected a wavelength and a value, got `500`",
            ),
            (
                "# n k\n400 0.1 2\n500 1 2\n",
                "line 2: expected a wavelength and a value",
            ),
            ("400 0.1\n\n500 x\n", "line 3: `x` is not a finite number"),
            (
                "400,0.1\n500,0.2\n",
                "line 1: expected a wavelength and a value",
            ),
            ("# empty\n", "at least two wavelengths, got 0"),
            ("500 0.1\n400 0.2\n", "the wavelengths must increase"),
        ];
        for (text, expected) in cases {
            let e = Spectrum::parse_spd(text).unwrap_err();
            assert!(e.contains(expected), "{text:?}: {e}");
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.spd");
        std::fs::write(&path, "400 0.1\n500 x\n").unwrap();
        let e = Spectrum::read_spd(&path).unwrap_err();
        assert!(
            e.contains("bad.spd") && e.contains("line 2: `x` is not a finite number"),
            "{e}"
        );
        std::fs::write(&path, vec![b'1'; MAX_SPD_BYTES as usize + 1]).unwrap();
        let e = Spectrum::read_spd(&path).unwrap_err();
        assert!(e.contains("longer than"), "{e}");
        std::fs::write(&path, b"400 0.1\n\xff\n").unwrap();
        let e = Spectrum::read_spd(&path).unwrap_err();
        assert!(e.contains("not UTF-8"), "{e}");
        let e = Spectrum::read_spd(&dir.path().join("gone.spd")).unwrap_err();
        assert!(
            e.contains("cannot read the spectrum file") && e.contains("gone.spd"),
            "{e}"
        );
    }
}
