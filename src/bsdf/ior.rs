//! Named indices of refraction (dielectrics) and named conductors (complex η + ik in RGB).

use crate::spectrum::Spectrum;

/// Mitsuba 3's table of named dielectric indices (documented in its `dielectric` plugin page and
/// `mitsuba/render/ior.h`), at ~589 nm.
const IOR_TABLE: &[(&str, f32)] = &[
    ("vacuum", 1.0),
    ("helium", 1.000036),
    ("hydrogen", 1.000132),
    ("air", 1.000277),
    ("carbon dioxide", 1.00045),
    ("water", 1.3330),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.470),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.5750),
    ("diamond", 2.419),
];

/// The index of a named dielectric (`"bk7"`, `"water"`, `"air"`, ...), as Mitsuba 3 names them.
pub fn named_ior(name: &str) -> Option<f32> {
    IOR_TABLE.iter().find(|(n, _)| *n == name).map(|&(_, v)| v)
}

/// Every accepted dielectric name (for error messages).
pub fn ior_names() -> impl Iterator<Item = &'static str> {
    IOR_TABLE.iter().map(|(n, _)| *n)
}

/// Named conductors: RGB (η, k) exactly as Mitsuba 3.9.1 `scalar_rgb` uses them. Mitsuba stores
/// tabulated spectral η(λ), k(λ) and converts them to RGB when loading in an RGB variant; these
/// numbers were read back from Mitsuba itself:
/// `mi.traverse(mi.load_dict({'type': 'conductor', 'material': NAME}))['eta.value' / 'k.value']`
/// (script: `tests/refs/bsdf_points.py`, function `conductors`). Negative RGB values were clamped
/// to 0 by Mitsuba (e.g. AlSb), and so are they here.
#[rustfmt::skip]
#[allow(clippy::excessive_precision)]
const CONDUCTOR_TABLE: &[(&str, [f32; 3], [f32; 3])] = &[
    ("a-C", [2.9440457820892334, 2.2271363735198975, 1.968161702156067], [0.8874648809432983, 0.7992985248565674, 0.8152899742126465]),
    ("Ag", [0.15527619421482086, 0.11672795563936234, 0.13838763535022736], [4.828354358673096, 3.122222423553467, 2.1469011306762695]),
    ("Al", [1.6575008630752563, 0.8804047107696533, 0.521244466304779], [9.223811149597168, 6.26950216293335, 4.8370041847229]),
    ("AlAs", [3.6052958965301514, 3.232937812805176, 2.2163186073303223], [0.0006794373039156199, 0.0, 0.007512709125876427]),
    ("AlSb", [0.0, 4.139374732971191, 4.669254302978516], [0.0, 0.09400907903909683, 1.300570011138916]),
    ("Au", [0.14303597807884216, 0.3753070831298828, 1.4420453310012817], [3.982996940612793, 2.38555645942688, 1.6033592224121094]),
    ("Be", [4.185012340545654, 3.1850292682647705, 2.7840611934661865], [3.835465908050537, 3.010122299194336, 2.8689939975738525]),
    ("Cr", [4.3696675300598145, 2.9165053367614746, 1.6549046039581299], [5.206546783447266, 4.231306076049805, 3.7546987533569336]),
    ("CsI", [2.144899606704712, 1.7023189067840576, 1.6624271869659424], [0.0, 0.0, 0.0]),
    ("Cu", [0.2010054737329483, 0.9237495064735413, 1.1022154092788696], [3.913262128829956, 2.453045129776001, 2.14208984375]),
    ("Cu2O", [3.5517725944519043, 2.9498696327209473, 2.751875400543213], [0.11420702189207077, 0.19389685988426208, 0.6061338782310486]),
    ("CuO", [3.2475409507751465, 2.447805166244507, 2.210219621658325], [0.5210895538330078, 0.5700307488441467, 0.7221789360046387]),
    ("d-C", [2.7087197303771973, 2.3188257217407227, 2.2288975715637207], [0.0, 0.0, 0.0]),
    ("Hg", [2.3989386558532715, 1.4400279521942139, 0.9095703959465027], [6.327587127685547, 4.371924877166748, 3.4217636585235596]),
    ("HgTe", [4.7790398597717285, 3.231196165084839, 2.6599011421203613], [1.6316126585006714, 1.5808104276657104, 1.7292873859405518]),
    ("Ir", [3.0862998962402344, 2.08219051361084, 1.6179145574569702], [5.592153072357178, 4.0670881271362305, 3.2673120498657227]),
    ("K", [0.06404318660497665, 0.046409767121076584, 0.038184914737939835], [2.1041996479034424, 1.3489400148391724, 0.9131258726119995]),
    ("Li", [0.2657909393310547, 0.19561831653118134, 0.22094862163066864], [3.5401549339294434, 2.3111233711242676, 1.668607234954834]),
    ("MgO", [2.0895838737487793, 1.6507234573364258, 1.5948790311813354], [4.332695226899608e-12, 0.0, 2.4986457347608848e-11]),
    ("Mo", [4.483973979949951, 3.5251307487487793, 2.776310443878174], [4.1114373207092285, 3.4208269119262695, 3.1506073474884033]),
    ("Na_palik", [0.06026935577392578, 0.056140948086977005, 0.061988431960344315], [3.1792733669281006, 2.11249041557312, 1.5790411233901978]),
    ("Nb", [3.420073986053467, 2.790093183517456, 2.395629405975342], [3.441394567489624, 2.737666130065918, 2.5797457695007324]),
    ("Ni_palik", [2.367304563522339, 1.6633731126785278, 1.4670780897140503], [4.498811721801758, 3.0501530170440674, 2.3454391956329346]),
    ("Rh", [2.5857934951782227, 1.8602163791656494, 1.5542633533477783], [6.782260417938232, 4.702987194061279, 3.9760730266571045]),
    ("Se", [4.058311462402344, 2.842935085296631, 2.8208534717559814], [0.75404953956604, 0.6384435296058655, 0.5218075513839722]),
    ("SiC", [3.1723415851593018, 2.5259716510772705, 2.479370594024658], [7.537663577750209e-07, 0.0, 1.0192530680797063e-05]),
    ("SnTe", [4.52424955368042, 1.9816449880599976, 1.2815912961959839], [0.0, 0.0, 0.0]),
    ("Ta", [2.062721014022827, 2.3929388523101807, 2.6279287338256836], [2.4083597660064697, 1.7414864301681519, 1.9470278024673462]),
    ("Te", [7.390233516693115, 4.482104778289795, 2.637105941772461], [3.2560222148895264, 3.5270588397979736, 3.2920541763305664]),
    ("ThF4", [1.8307136297225952, 1.4422285556793213, 1.3876476287841797], [0.0, 0.0, 0.0]),
    ("TiC", [3.700528383255005, 2.8374221324920654, 2.582287073135376], [3.2656350135803223, 2.3515892028808594, 2.17279052734375]),
    ("TiN", [1.6484496593475342, 1.1505160331726074, 1.3798234462738037], [3.368328094482422, 1.943498134613037, 1.1020677089691162]),
    ("TiO2", [3.4566099643707275, 2.8017358779907227, 2.905174970626831], [0.00010526483674766496, 0.0, 0.0006528865196742117]),
    ("VC", [3.6575660705566406, 2.7527360916137695, 2.5326719284057617], [3.068300724029541, 2.1986873149871826, 1.9631927013397217]),
    ("V_palik", [4.277582168579102, 3.512948751449585, 2.7610714435577393], [3.4913008213043213, 2.8894548416137695, 3.1115219593048096]),
    ("VN", [2.8656022548675537, 2.1191890239715576, 1.9400911331176758], [3.0322425365448, 2.0561156272888184, 1.6163063049316406]),
    ("W", [4.370816707611084, 3.300246477127075, 2.9984073638916016], [3.500640630722046, 2.6048738956451416, 2.27323317527771]),
];

/// (η, k) of a named conductor in RGB; `"none"` is Mitsuba's perfect mirror (η 0, k 1).
pub fn named_conductor(name: &str) -> Option<(Spectrum, Spectrum)> {
    if name == "none" {
        return Some((Spectrum::splat(0.0), Spectrum::splat(1.0)));
    }
    CONDUCTOR_TABLE
        .iter()
        .find(|(n, _, _)| *n == name)
        .map(|(_, e, k)| (Spectrum::from_array(*e), Spectrum::from_array(*k)))
}

/// Every accepted conductor name (for error messages).
pub fn conductor_names() -> impl Iterator<Item = &'static str> {
    std::iter::once("none").chain(CONDUCTOR_TABLE.iter().map(|(n, _, _)| *n))
}

/// Reading indices from the scene file: `int_ior`/`ext_ior` as a number or a name, a
/// conductor's `material` or `eta`/`k`.
pub(crate) mod load {
    use super::{named_conductor, named_ior};
    use crate::error::{Error, Result};
    use crate::load::check;
    use crate::scene::xml::props::Props;
    use crate::spectrum::{Spectrum, SpectrumUse};

    /// An index of refraction given as a number or by name (`bk7`, `water`, `air`, ...).
    pub(crate) fn ior_param(p: &Props, name: &str, default: f32) -> Result<f32> {
        let v = match p.property_node(name) {
            None => default,
            Some(node) if node.tag == "string" => {
                let s = node.attr("value").unwrap_or("");
                named_ior(s).ok_or_else(|| {
                    Error::scene(
                        &node.loc,
                        format!("unknown index of refraction '{s}' (e.g. bk7, water, air, vacuum)"),
                    )
                })?
            }
            Some(_) => p.float(name, default)?,
        };
        check(
            p.loc(),
            v.is_finite() && v > 0.0,
            format!("{name} must be positive"),
        )?;
        Ok(v)
    }

    /// `material` (a named conductor) or explicit `eta` and `k`.
    pub(crate) fn conductor_ior(p: &Props) -> Result<(Spectrum, Spectrum)> {
        if p.has("eta") || p.has("k") {
            if p.has("material") {
                return Err(Error::scene(
                    p.loc(),
                    "give either 'material' or 'eta'/'k', not both",
                ));
            }
            let eta = p.color_with("eta", Spectrum::ZERO, SpectrumUse::Unbounded)?;
            let k = p.color_with("k", Spectrum::ONE, SpectrumUse::Unbounded)?;
            return Ok((eta, k));
        }
        let name = p.string("material", "none")?;
        named_conductor(&name).ok_or_else(|| {
            Error::scene(
                p.loc(),
                format!("unknown conductor material '{name}' (e.g. none, Au, Ag, Cu, Al, Cr)"),
            )
        })
    }
}
