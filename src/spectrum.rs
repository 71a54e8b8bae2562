//! Colour: linear Rec.709 RGB. Conversion of `wavelength:value` spectra to RGB lives here.

pub type Spectrum = glam::Vec3;

/// Luminance (Rec.709 weights) of a linear RGB value.
#[inline]
pub fn luminance(c: Spectrum) -> f32 {
    0.212671 * c.x + 0.715160 * c.y + 0.072169 * c.z
}

/// Largest component.
#[inline]
pub fn max_component(c: Spectrum) -> f32 {
    c.x.max(c.y).max(c.z)
}

/// True when every component is finite.
#[inline]
pub fn is_finite(c: Spectrum) -> bool {
    c.x.is_finite() && c.y.is_finite() && c.z.is_finite()
}

/// How a `wavelength:value` spectrum is used; Mitsuba 3 converts it to RGB differently for each
/// (`spectrum_list_to_srgb(.., bounded, d65)` as called by its XML parser in RGB variants, checked
/// against Mitsuba 3.9.1 with `mi.load_string`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpectrumUse {
    /// A reflectance-like value (BSDF parameters, textures): weighted by D65, clamped to [0, 1].
    Reflectance,
    /// Inside an `<emitter>`: plain CIE integration (no D65), negative values clamped to 0.
    Emission,
    /// An unbounded non-emissive value (e.g. a conductor's `eta`, `k`): weighted by D65, negative
    /// values clamped to 0.
    Unbounded,
}

/// Result of converting a tabulated spectrum: the RGB value and whether it had to be clamped
/// (Mitsuba logs a warning "clamping out-of-gamut color" in that case).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConvertedSpectrum {
    pub rgb: Spectrum,
    pub clamped: bool,
    /// The value before clamping.
    pub unclamped: Spectrum,
}

/// Wavelength range of the tables (nm) and their sample count (5 nm spacing).
const CIE_MIN: f64 = 360.0;
const CIE_MAX: f64 = 830.0;
const CIE_SAMPLES: usize = 95;
/// Scale that makes the tabulated D65 illuminant integrate to a luminance of 1
/// (Mitsuba's `MI_CIE_D65_NORMALIZATION`).
const D65_NORMALIZATION: f64 = 1.0 / 98.99741751876255;
/// Scale that makes a unit spectrum integrate to a luminance of 1 (Mitsuba's
/// `MI_CIE_Y_NORMALIZATION`, applied by 3.9.1's `spectrum_list_to_srgb`).
const Y_NORMALIZATION: f64 = 1.0 / 106.750_259_399_414_06;

/// Linear interpolation in one of the 5 nm tables; zero outside [360, 830] nm.
fn table_lookup(table: &[f64; CIE_SAMPLES], w: f64) -> f64 {
    if !(CIE_MIN..=CIE_MAX).contains(&w) {
        return 0.0;
    }
    let t = (w - CIE_MIN) * ((CIE_SAMPLES - 1) as f64 / (CIE_MAX - CIE_MIN));
    let i0 = (t as usize).min(CIE_SAMPLES - 2);
    let f = t - i0 as f64;
    (1.0 - f) * table[i0] + f * table[i0 + 1]
}

/// CIE 1931 2° colour matching functions at wavelength `w` (nm).
pub fn cie1931_xyz(w: f64) -> [f64; 3] {
    [
        table_lookup(&CIE_X, w),
        table_lookup(&CIE_Y, w),
        table_lookup(&CIE_Z, w),
    ]
}

/// XYZ to linear Rec.709 / sRGB (the matrix Mitsuba 3 uses in `xyz_to_srgb`).
pub fn xyz_to_linear_srgb(xyz: [f64; 3]) -> [f64; 3] {
    let [x, y, z] = xyz;
    [
        3.240479 * x - 1.537150 * y - 0.498535 * z,
        -0.969256 * x + 1.875991 * y + 0.041556 * z,
        0.055648 * x - 0.204043 * y + 1.057311 * z,
    ]
}

/// Converts a piecewise-linear spectrum (`wavelengths` strictly increasing, in nm, at least two
/// entries) to linear sRGB as Mitsuba 3's RGB variants do when loading `<spectrum value="λ:v, ...">`:
/// 1000 evenly spaced samples over [360, 830] nm, each inside the given range weighted by the CIE
/// curves (and by the normalised D65 illuminant unless `use_` is [`SpectrumUse::Emission`]), then
/// XYZ (normalised so that a unit spectrum has luminance 1) → sRGB and clamping. The spectrum is zero outside its given range.
pub fn spectrum_list_to_rgb(
    wavelengths: &[f64],
    values: &[f64],
    use_: SpectrumUse,
) -> std::result::Result<ConvertedSpectrum, String> {
    if wavelengths.len() != values.len() {
        return Err("wavelength and value lists differ in length".into());
    }
    if wavelengths.len() < 2 {
        return Err("a tabulated spectrum needs at least two wavelength:value pairs".into());
    }
    if wavelengths.windows(2).any(|w| w[1] <= w[0]) {
        return Err("wavelengths must be strictly increasing".into());
    }
    if wavelengths.iter().chain(values).any(|v| !v.is_finite()) {
        return Err("spectrum contains a non-finite number".into());
    }
    let d65 = use_ != SpectrumUse::Emission;
    const STEPS: usize = 1000;
    let (first, last) = (wavelengths[0], wavelengths[wavelengths.len() - 1]);
    let mut xyz = [0.0f64; 3];
    for i in 0..STEPS {
        let w = CIE_MIN + (i as f64 / (STEPS - 1) as f64) * (CIE_MAX - CIE_MIN);
        if w < first || w > last {
            continue;
        }
        // Largest index with wavelengths[idx] <= w, kept inside [0, n-2].
        let idx = wavelengths
            .partition_point(|&x| x <= w)
            .saturating_sub(1)
            .min(wavelengths.len() - 2);
        let (w0, w1) = (wavelengths[idx], wavelengths[idx + 1]);
        let (v0, v1) = (values[idx], values[idx + 1]);
        let v = ((w - w1) * v0 + (w0 - w) * v1) / (w0 - w1);
        let weight = if d65 {
            table_lookup(&D65, w) * D65_NORMALIZATION
        } else {
            1.0
        };
        let c = cie1931_xyz(w);
        for k in 0..3 {
            xyz[k] += c[k] * v * weight;
        }
    }
    let scale = (CIE_MAX - CIE_MIN) / STEPS as f64 * Y_NORMALIZATION;
    let rgb = xyz_to_linear_srgb(xyz.map(|c| c * scale));
    let unclamped = Spectrum::new(rgb[0] as f32, rgb[1] as f32, rgb[2] as f32);
    let out = match use_ {
        SpectrumUse::Reflectance => unclamped.clamp(Spectrum::ZERO, Spectrum::ONE),
        SpectrumUse::Emission | SpectrumUse::Unbounded => unclamped.max(Spectrum::ZERO),
    };
    Ok(ConvertedSpectrum {
        rgb: out,
        clamped: out != unclamped,
        unclamped,
    })
}

// CIE 1931 2° standard observer colour matching functions and the CIE standard illuminant D65
// (relative spectral power), 360–830 nm in 5 nm steps. Public CIE data (CIE 015:2018 tables).
const CIE_X: [f64; 95] = [
    0.0001299,
    0.0002321,
    0.0004149,
    0.0007416,
    0.001368,
    0.002236,
    0.004243,
    0.00765,
    0.01431,
    0.02319,
    0.04351,
    0.07763,
    0.13438,
    0.21477,
    0.2839,
    0.3285,
    0.34828,
    0.34806,
    0.3362,
    0.3187,
    0.2908,
    0.2511,
    0.19536,
    0.1421,
    0.09564,
    0.05795001,
    0.03201,
    0.0147,
    0.0049,
    0.0024,
    0.0093,
    0.0291,
    0.06327,
    0.1096,
    0.1655,
    0.2257499,
    0.2904,
    0.3597,
    0.4334499,
    0.5120501,
    0.5945,
    0.6784,
    0.7621,
    0.8425,
    0.9163,
    0.9786,
    1.0263,
    1.0567,
    1.0622,
    1.0456,
    1.0026,
    0.9384,
    0.8544499,
    0.7514,
    0.6424,
    0.5419,
    0.4479,
    0.3608,
    0.2835,
    0.2187,
    0.1649,
    0.1212,
    0.0874,
    0.0636,
    0.04677,
    0.0329,
    0.0227,
    0.01584,
    0.01135916,
    0.008110916,
    0.005790346,
    0.004109457,
    0.002899327,
    0.00204919,
    0.001439971,
    0.0009999493,
    0.0006900786,
    0.0004760213,
    0.0003323011,
    0.0002348261,
    0.0001661505,
    0.000117413,
    8.307527e-05,
    5.870652e-05,
    4.150994e-05,
    2.935326e-05,
    2.067383e-05,
    1.455977e-05,
    1.025398e-05,
    7.221456e-06,
    5.085868e-06,
    3.581652e-06,
    2.522525e-06,
    1.776509e-06,
    1.251141e-06,
];
const CIE_Y: [f64; 95] = [
    3.917e-06, 6.965e-06, 1.239e-05, 2.202e-05, 3.9e-05, 6.4e-05, 0.00012, 0.000217, 0.000396,
    0.00064, 0.00121, 0.00218, 0.004, 0.0073, 0.0116, 0.01684, 0.023, 0.0298, 0.038, 0.048, 0.06,
    0.0739, 0.09098, 0.1126, 0.13902, 0.1693, 0.20802, 0.2586, 0.323, 0.4073, 0.503, 0.6082, 0.71,
    0.7932, 0.862, 0.9148501, 0.954, 0.9803, 0.9949501, 1.0, 0.995, 0.9786, 0.952, 0.9154, 0.87,
    0.8163, 0.757, 0.6949, 0.631, 0.5668, 0.503, 0.4412, 0.381, 0.321, 0.265, 0.217, 0.175, 0.1382,
    0.107, 0.0816, 0.061, 0.04458, 0.032, 0.0232, 0.017, 0.01192, 0.00821, 0.005723, 0.004102,
    0.002929, 0.002091, 0.001484, 0.001047, 0.00074, 0.00052, 0.0003611, 0.0002492, 0.0001719,
    0.00012, 8.48e-05, 6e-05, 4.24e-05, 3e-05, 2.12e-05, 1.499e-05, 1.06e-05, 7.4657e-06,
    5.2578e-06, 3.7029e-06, 2.6078e-06, 1.8366e-06, 1.2934e-06, 9.1093e-07, 6.4153e-07, 4.5181e-07,
];
const CIE_Z: [f64; 95] = [
    0.0006061,
    0.001086,
    0.001946,
    0.003486,
    0.006450001,
    0.01054999,
    0.02005001,
    0.03621,
    0.06785001,
    0.1102,
    0.2074,
    0.3713,
    0.6456,
    1.03905,
    1.3856,
    1.62296,
    1.74706,
    1.7826,
    1.77211,
    1.7441,
    1.6692,
    1.5281,
    1.28764,
    1.0419,
    0.8129501,
    0.6162,
    0.46518,
    0.3533,
    0.272,
    0.2123,
    0.1582,
    0.1117,
    0.07824999,
    0.05725001,
    0.04216,
    0.02984,
    0.0203,
    0.0134,
    0.008749999,
    0.005749999,
    0.0039,
    0.002749999,
    0.0021,
    0.0018,
    0.001650001,
    0.0014,
    0.0011,
    0.001,
    0.0008,
    0.0006,
    0.00034,
    0.00024,
    0.00019,
    0.0001,
    4.999999e-05,
    3e-05,
    2e-05,
    1e-05,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
];
const D65: [f64; 95] = [
    46.6383, 49.3637, 52.0891, 51.0323, 49.9755, 52.3118, 54.6482, 68.7015, 82.7549, 87.1204,
    91.486, 92.4589, 93.4318, 90.057, 86.6823, 95.7736, 104.865, 110.936, 117.008, 117.41, 117.812,
    116.336, 114.861, 115.392, 115.923, 112.367, 108.811, 109.082, 109.354, 108.578, 107.802,
    106.296, 104.79, 106.239, 107.689, 106.047, 104.405, 104.225, 104.046, 102.023, 100.0, 98.1671,
    96.3342, 96.0611, 95.788, 92.2368, 88.6856, 89.3459, 90.0062, 89.8026, 89.5991, 88.6489,
    87.6987, 85.4936, 83.2886, 83.4939, 83.6992, 81.863, 80.0268, 80.1207, 80.2146, 81.2462,
    82.2778, 80.281, 78.2842, 74.0027, 69.7213, 70.6652, 71.6091, 72.979, 74.349, 67.9765, 61.604,
    65.7448, 69.8856, 72.4863, 75.087, 69.3398, 63.5927, 55.0054, 46.4182, 56.6118, 66.8054,
    65.0941, 63.3828, 63.8434, 64.304, 61.8779, 59.4519, 55.7054, 51.959, 54.6998, 57.4406,
    58.8765, 60.3125,
];

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_list(s: &str) -> (Vec<f64>, Vec<f64>) {
        s.split(',')
            .map(|p| {
                let (w, v) = p.trim().split_once(':').unwrap();
                (w.parse::<f64>().unwrap(), v.parse::<f64>().unwrap())
            })
            .unzip()
    }

    fn assert_close(got: Spectrum, want: [f32; 3]) {
        for k in 0..3 {
            let rel = (got[k] - want[k]).abs() / want[k].abs().max(1e-6);
            assert!(rel < 1e-3, "component {k}: got {got:?}, want {want:?}");
        }
    }

    // Reference values: Mitsuba 3.9.1, scalar_rgb, `mi.load_string` of a diffuse BSDF / area emitter
    // with these spectra from scenes/mitsuba_cbox/cbox.xml, read back with `mi.traverse`.
    const WHITE: &str = "400:0.343, 404:0.445, 408:0.551, 412:0.624, 416:0.665, 420:0.687, 424:0.708, 428:0.723, 432:0.715, 436:0.71, 440:0.745, 444:0.758, 448:0.739, 452:0.767, 456:0.777, 460:0.765, 464:0.751, 468:0.745, 472:0.748, 476:0.729, 480:0.745, 484:0.757, 488:0.753, 492:0.75, 496:0.746, 500:0.747, 504:0.735, 508:0.732, 512:0.739, 516:0.734, 520:0.725, 524:0.721, 528:0.733, 532:0.725, 536:0.732, 540:0.743, 544:0.744, 548:0.748, 552:0.728, 556:0.716, 560:0.733, 564:0.726, 568:0.713, 572:0.74, 576:0.754, 580:0.764, 584:0.752, 588:0.736, 592:0.734, 596:0.741, 600:0.74, 604:0.732, 608:0.745, 612:0.755, 616:0.751, 620:0.744, 624:0.731, 628:0.733, 632:0.744, 636:0.731, 640:0.712, 644:0.708, 648:0.729, 652:0.73, 656:0.727, 660:0.707, 664:0.703, 668:0.729, 672:0.75, 676:0.76, 680:0.751, 684:0.739, 688:0.724, 692:0.73, 696:0.74, 700:0.737";
    const RED: &str = "400:0.04, 404:0.046, 408:0.048, 412:0.053, 416:0.049, 420:0.05, 424:0.053, 428:0.055, 432:0.057, 436:0.056, 440:0.059, 444:0.057, 448:0.061, 452:0.061, 456:0.06, 460:0.062, 464:0.062, 468:0.062, 472:0.061, 476:0.062, 480:0.06, 484:0.059, 488:0.057, 492:0.058, 496:0.058, 500:0.058, 504:0.056, 508:0.055, 512:0.056, 516:0.059, 520:0.057, 524:0.055, 528:0.059, 532:0.059, 536:0.058, 540:0.059, 544:0.061, 548:0.061, 552:0.063, 556:0.063, 560:0.067, 564:0.068, 568:0.072, 572:0.08, 576:0.09, 580:0.099, 584:0.124, 588:0.154, 592:0.192, 596:0.255, 600:0.287, 604:0.349, 608:0.402, 612:0.443, 616:0.487, 620:0.513, 624:0.558, 628:0.584, 632:0.62, 636:0.606, 640:0.609, 644:0.651, 648:0.612, 652:0.61, 656:0.65, 660:0.638, 664:0.627, 668:0.62, 672:0.63, 676:0.628, 680:0.642, 684:0.639, 688:0.657, 692:0.639, 696:0.635, 700:0.642";
    const GREEN: &str = "400:0.092, 404:0.096, 408:0.098, 412:0.097, 416:0.098, 420:0.095, 424:0.095, 428:0.097, 432:0.095, 436:0.094, 440:0.097, 444:0.098, 448:0.096, 452:0.101, 456:0.103, 460:0.104, 464:0.107, 468:0.109, 472:0.112, 476:0.115, 480:0.125, 484:0.14, 488:0.16, 492:0.187, 496:0.229, 500:0.285, 504:0.343, 508:0.39, 512:0.435, 516:0.464, 520:0.472, 524:0.476, 528:0.481, 532:0.462, 536:0.447, 540:0.441, 544:0.426, 548:0.406, 552:0.373, 556:0.347, 560:0.337, 564:0.314, 568:0.285, 572:0.277, 576:0.266, 580:0.25, 584:0.23, 588:0.207, 592:0.186, 596:0.171, 600:0.16, 604:0.148, 608:0.141, 612:0.136, 616:0.13, 620:0.126, 624:0.123, 628:0.121, 632:0.122, 636:0.119, 640:0.114, 644:0.115, 648:0.117, 652:0.117, 656:0.118, 660:0.12, 664:0.122, 668:0.128, 672:0.132, 676:0.139, 680:0.144, 684:0.146, 688:0.15, 692:0.152, 696:0.157, 700:0.159";
    const LIGHT: &str = "400:0, 500:8, 600:15.6, 700:18.4";

    #[test]
    fn cbox_spectra_match_mitsuba() {
        let cases = [
            (
                WHITE,
                SpectrumUse::Reflectance,
                [0.735013, 0.735625, 0.736264],
            ),
            (
                RED,
                SpectrumUse::Reflectance,
                [0.49132, 0.0492281, 0.0509219],
            ),
            (
                GREEN,
                SpectrumUse::Reflectance,
                [0.0682825, 0.39776, 0.0862909],
            ),
            (LIGHT, SpectrumUse::Emission, [20.7108, 10.8546, 2.77115]),
            (LIGHT, SpectrumUse::Unbounded, [17.7147, 11.3544, 3.30451]),
        ];
        for (s, u, want) in cases {
            let (w, v) = parse_list(s);
            let got = spectrum_list_to_rgb(&w, &v, u).unwrap();
            assert_close(got.rgb, want);
        }
    }

    #[test]
    fn reflectance_is_clamped_like_mitsuba() {
        let (w, v) = parse_list(LIGHT);
        let got = spectrum_list_to_rgb(&w, &v, SpectrumUse::Reflectance).unwrap();
        assert!(got.clamped);
        assert_eq!(got.rgb, Spectrum::ONE);
        assert_close(got.unclamped, [17.7147, 11.3544, 3.30451]);
    }

    #[test]
    fn bad_lists_are_errors() {
        assert!(spectrum_list_to_rgb(&[400.0], &[1.0], SpectrumUse::Emission).is_err());
        assert!(spectrum_list_to_rgb(&[500.0, 400.0], &[1.0, 1.0], SpectrumUse::Emission).is_err());
        assert!(
            spectrum_list_to_rgb(&[400.0, 500.0], &[1.0, f64::NAN], SpectrumUse::Emission).is_err()
        );
    }
}
