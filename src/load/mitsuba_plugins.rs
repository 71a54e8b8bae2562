//! The plugins of Mitsuba 3.9.1 (the `mitsuba/plugins` folder of its Python package, with the
//! kind each one is, from its source folder), so that a scene naming one that groove lacks gets
//! "Mitsuba plugin 'X' (KIND) is not supported by groove" rather than "unknown plugin", and the
//! polarisation plugins say what they need.

/// Mitsuba 3.9.1's plugins by kind.
const MITSUBA_PLUGINS: &[(&str, &[&str])] = &[
    (
        "bsdf",
        &[
            "blendbsdf",
            "bumpmap",
            "circular",
            "conductor",
            "dielectric",
            "diffuse",
            "hair",
            "mask",
            "measured",
            "measured_polarized",
            "normalmap",
            "null",
            "plastic",
            "polarizer",
            "pplastic",
            "principled",
            "principledthin",
            "retarder",
            "roughconductor",
            "roughdielectric",
            "roughplastic",
            "thindielectric",
            "twosided",
        ],
    ),
    (
        "emitter",
        &[
            "area",
            "constant",
            "directional",
            "directionalarea",
            "envmap",
            "point",
            "projector",
            "spot",
            "sunsky",
            "timed_sunsky",
        ],
    ),
    ("film", &["hdrfilm", "specfilm"]),
    (
        "integrator",
        &[
            "aov",
            "depth",
            "direct",
            "moment",
            "path",
            "ptracer",
            "stokes",
            "volpath",
            "volpathmis",
        ],
    ),
    ("medium", &["heterogeneous", "homogeneous"]),
    (
        "phase",
        &[
            "blendphase",
            "hg",
            "isotropic",
            "rayleigh",
            "sggx",
            "tabphase",
        ],
    ),
    (
        "rfilter",
        &[
            "box",
            "catmullrom",
            "gaussian",
            "lanczos",
            "mitchell",
            "tent",
        ],
    ),
    (
        "sampler",
        &[
            "independent",
            "ldsampler",
            "multijitter",
            "orthogonal",
            "stratified",
        ],
    ),
    (
        "sensor",
        &[
            "batch",
            "distant",
            "irradiancemeter",
            "orthographic",
            "perspective",
            "radiancemeter",
            "thinlens",
        ],
    ),
    (
        "shape",
        &[
            "blender",
            "bsplinecurve",
            "cube",
            "cylinder",
            "disk",
            "ellipsoids",
            "ellipsoidsmesh",
            "instance",
            "linearcurve",
            "merge",
            "obj",
            "ply",
            "rectangle",
            "sdfgrid",
            "serialized",
            "shapegroup",
            "sphere",
        ],
    ),
    (
        "spectrum",
        &[
            "blackbody",
            "d65",
            "irregular",
            "rawconstant",
            "regular",
            "srgb",
            "uniform",
        ],
    ),
    (
        "texture",
        &["bitmap", "checkerboard", "mesh_attribute", "volume"],
    ),
    ("volume", &["constvolume", "gridvolume"]),
];

/// Mitsuba's plugins that only work in its polarised variants (`*_polarized`).
const POLARISED: &[&str] = &[
    "polarizer",
    "pplastic",
    "measured_polarized",
    "retarder",
    "circular",
    "stokes",
];

/// What Mitsuba 3.9.1 calls plugin `name`: its kind (`bsdf`, `shape`, ...) when it exists.
pub(crate) fn mitsuba_kind(name: &str) -> Option<&'static str> {
    MITSUBA_PLUGINS
        .iter()
        .find(|(_, names)| names.contains(&name))
        .map(|(kind, _)| *kind)
}

/// True for a Mitsuba plugin that needs a polarised variant.
pub(crate) fn is_polarised(name: &str) -> bool {
    POLARISED.contains(&name)
}
