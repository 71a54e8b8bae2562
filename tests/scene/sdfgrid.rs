//! `sdfgrid` against Mitsuba 3.9.1 (`scalar_rgb`) point by point: hit distance, point, geometric
//! and shading normals of rays at two generated grids (`tests/data/sdfgrid/`, written by
//! `tests/refs/make_sdfgrids.py`, which also prints these rows with `--points`): a 16³ torus with
//! `smooth` normals, the same under a non-uniform scale with `analytic` normals, and a wavy
//! ellipsoid on a 12 × 9 × 12 grid. Plus the loader's errors, among them the grid of unequal x
//! and z sizes that Mitsuba mis-indexes (see `src/geometry/sdfgrid.rs`). Run
//! with `cargo test --release --test scene sdfgrid`.

// Mitsuba's values are quoted as printed.
#![allow(clippy::excessive_precision)]

use glam::Vec3;
use groove::geometry::Ray;
use groove::load::options::LoadOptions;
use groove::load::{load_scene, Loaded};

/// o, d, and Mitsuba's hit: t, p, n, sh_frame.n (or a miss).
type Row = (
    [f32; 3],
    [f32; 3],
    Option<(f32, [f32; 3], [f32; 3], [f32; 3])>,
);

fn scene_text(body: &str) -> String {
    format!(
        "<?xml version=\"1.0\"?>\n<scene version=\"3.0.0\">\n{body}\n<sensor type=\"perspective\"/>\n</scene>\n"
    )
}

fn write_scene(name: &str, body: &str) -> crate::common::ScratchFile {
    let dir = crate::common::Scratch::new(&format!("groove_sdf_{}_{name}", std::process::id()));
    let path = crate::common::ScratchFile::new(dir, "scene.xml");
    std::fs::write(&path, scene_text(body)).unwrap();
    path
}

fn grid_file(name: &str) -> String {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/sdfgrid")
        .join(name);
    p.to_str().unwrap().to_string()
}

fn load(name: &str, file: &str, normals: &str, xf: &str) -> Loaded {
    let body = format!(
        r#"<shape type="sdfgrid"><string name="filename" value="{}"/><string name="normals" value="{normals}"/>{xf}</shape>"#,
        grid_file(file)
    );
    load_scene(&write_scene(name, &body), &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

/// Every row's hit or miss as Mitsuba's: t within 1e-5 relative, the point and the normals
/// within 1e-5 (single-precision root refinement and texture arithmetic in both; measured ≤ 2e-6).
fn check(what: &str, l: &Loaded, rows: &[Row]) {
    let mut hits = 0;
    let mut worst = [0.0f32; 4];
    for (o, d, want) in rows {
        let ray = Ray::new(Vec3::from(*o), Vec3::from(*d).normalize());
        let got = l.scene.intersect(&ray);
        match (want, got) {
            (None, None) => {}
            (Some((t, p, n, sh)), Some(si)) => {
                hits += 1;
                let dev = [
                    (si.t - t).abs() / t,
                    (si.p - Vec3::from(*p)).length(),
                    (si.ng - Vec3::from(*n)).length(),
                    (si.sh.n - Vec3::from(*sh)).length(),
                ];
                for (w, d) in worst.iter_mut().zip(dev) {
                    *w = w.max(d);
                }
                assert!(
                    (si.t - t).abs() <= 1e-5 * t,
                    "{what} {o:?}: t {} vs {t}",
                    si.t
                );
                assert!(
                    (si.p - Vec3::from(*p)).length() <= 1e-5,
                    "{what} {o:?}: p {}",
                    si.p
                );
                assert!(
                    (si.ng - Vec3::from(*n)).length() <= 1e-5,
                    "{what} {o:?}: n {} vs {n:?}",
                    si.ng
                );
                assert!(
                    (si.sh.n - Vec3::from(*sh)).length() <= 1e-5,
                    "{what} {o:?}: sh {} vs {sh:?}",
                    si.sh.n
                );
            }
            (w, g) => panic!("{what} {o:?}: Mitsuba {w:?}, groove {:?}", g.map(|s| s.t)),
        }
    }
    eprintln!(
        "{what}: {hits} hits, {} misses, all as Mitsuba; largest |Δt|/t {:.1e}, |Δp| {:.1e}, |Δn| {:.1e}, |Δsh| {:.1e}",
        rows.len() - hits,
        worst[0],
        worst[1],
        worst[2],
        worst[3]
    );
}

#[rustfmt::skip]
const TORUS_SMOOTH: &[Row] = &[
    ([-2.0, 0.01295605, 0.5993456], [0.9916645, 0.1284721, -0.009817643], None),
    ([3.0, 0.409423, 0.8922225], [-0.985901, -0.0434441, -0.1615914], None),
    ([0.6026497, -0.04049282, -2.0], [-0.08606824, 0.215754, 0.9726471], Some((2.195667, [0.4136725, 0.4332312, 0.1356095], [-0.1612651, -0.6302317, -0.7594746], [-0.1935724, -0.5862398, -0.7866719]))),
    ([0.2701782, 0.8793516, -2.0], [0.01816064, -0.1642672, 0.9862487], Some((2.185459, [0.3098675, 0.5203524, 0.1554064], [-0.5046539, -2.146471e-08, -0.8633218], [-0.4759383, 0.1480054, -0.8669355]))),
    ([-2.0, 0.6428115, 0.4956974], [0.9967231, -0.08014756, 0.01092936], Some((2.113412, [0.1064867, 0.4734267, 0.5187957], [-1.0, -2.313432e-08, 4.395554e-09], [-0.9798634, -0.1941856, 0.04647078]))),
    ([0.2597204, 3.0, 0.7387933], [0.1488369, -0.9888046, -0.01063465], Some((2.415843, [0.619287, 0.6112031, 0.7131017], [-0.1250484, 0.9397554, -0.318155], [-0.1339365, 0.9599891, -0.2459309]))),
    ([0.438601, 0.6307508, -2.0], [0.03663145, -0.04389072, 0.9983645], Some((2.112463, [0.5159836, 0.5380333, 0.1090083], [-1.929763e-08, 0.4781087, -0.8783006], [0.03904607, 0.2868965, -0.9571655]))),
    ([-0.05295129, -2.0, 0.817485], [0.1570891, 0.9867287, -0.04110301], Some((2.414764, [0.3263819, 0.3827172, 0.718231], [-0.09386238, -0.9910254, -0.09517572], [-0.01642786, -0.9998645, 0.001056498]))),
    ([0.4960098, 0.8562704, 3.0], [0.07820786, -0.1833125, -0.9799388], Some((2.194504, [0.6676372, 0.4539903, 0.8495201], [0.4335983, -0.4989209, 0.7503803], [0.3991472, -0.3599423, 0.8432811]))),
    ([0.7417904, 0.6765546, -2.0], [-0.154365, -0.03375827, 0.987437], Some((2.20522, [0.4013817, 0.6021102, 0.1775158], [-0.07642101, 0.8649265, -0.4960464], [-0.1461243, 0.8776986, -0.4563912]))),
    ([3.0, 0.3265569, 0.6331035], [-0.9988319, 0.04456141, -0.01868316], Some((2.149288, [0.8532226, 0.4223322, 0.592948], [0.7097947, -0.689536, 0.1439853], [0.7143302, -0.6733029, 0.1907762]))),
    ([0.3691396, 3.0, -0.003302439], [-0.003745232, -0.972636, 0.2323041], Some((2.532368, [0.3596554, 0.5369276, 0.5849771], [0.7696904, 0.4958953, -0.4020754], [0.826749, 0.2783605, -0.4888778]))),
];

#[rustfmt::skip]
const TORUS_ANALYTIC: &[Row] = &[
    ([-3.0, 0.2194341, 0.5993456], [0.9864691, 0.1637352, -0.008341597], Some((3.483195, [0.4360636, 0.7897556, 0.5702902], [-0.3565375, -0.9161333, -0.1832505], [-0.3565375, -0.9161333, -0.1832505]))),
    ([3.0, 0.8141346, 0.8922225], [-0.9900462, -0.05263914, -0.1305284], None),
    ([0.2052994, 0.1392608, -2.0], [-0.1656069, 0.311355, 0.9357523], Some((2.282238, [-0.172655, 0.8498468, 0.1356093], [-0.09250212, -0.4820026, -0.871273], [-0.09250212, -0.4820026, -0.871273]))),
    ([-0.4596436, 1.519027, -2.0], [0.03570671, -0.2422316, 0.9695612], Some((2.223074, [-0.380265, 0.9805287, 0.1554064], [-0.2805376, -2.582534e-09, -0.959843], [-0.2805376, -2.582534e-09, -0.959843]))),
    ([-3.0, 1.164217, 0.4956974], [0.9951214, -0.09825284, 0.008932194], Some((2.223823, [-0.7870265, 0.9457205, 0.515561], [-1.0, -1.484393e-08, 6.015864e-09], [-1.0, -1.484393e-08, 6.015864e-09]))),
    ([-0.4805592, 3.7, 0.7387933], [0.263349, -0.9646548, -0.00940837], Some((2.678981, [0.2249476, 1.115709, 0.7135885], [-0.0862193, 0.8706897, -0.4842164], [-0.0862193, 0.8706897, -0.4842164]))),
    ([-0.1227979, 1.146126, -2.0], [0.07302837, -0.06562532, 0.9951684], Some((2.119248, [0.03196726, 1.00705, 0.1090083], [1.773308e-09, 0.3411352, -0.9400142], [1.773308e-09, 0.3411352, -0.9400142]))),
    ([-1.105903, -1.8, 0.817485], [0.2809296, 0.9590244, -0.03675318], Some((2.684314, [-0.3517992, 0.7743228, 0.718828], [-0.07230193, -0.9890991, -0.1282786], [-0.07230193, -0.9890991, -0.1282786]))),
    ([-0.007980491, 1.484406, 3.0], [0.151899, -0.2670287, -0.9516419], Some((2.259758, [0.3352745, 0.8809856, 0.84952], [0.2553753, -0.3917978, 0.8838993], [0.2553753, -0.3917978, 0.8838993]))),
    ([0.4835809, 1.214832, -2.0], [-0.2980555, -0.0488866, 0.9532959], Some((2.284197, [-0.1972366, 1.103165, 0.1775157], [-0.05017252, 0.7571294, -0.6513354], [-0.05017252, 0.7571294, -0.6513354]))),
    ([3.0, 0.6898354, 0.6331035], [-0.998416, 0.05418658, -0.01514579], Some((2.324316, [0.6793658, 0.8157821, 0.5978999], [0.5304617, -0.82464, 0.1964165], [0.5304617, -0.82464, 0.1964165]))),
    ([-0.2617207, 3.7, -0.003302439], [-0.006745955, -0.9778465, 0.2092144], Some((2.791528, [-0.2805522, 0.9703146, 0.5807254], [0.6966329, -1.089609e-08, -0.7174277], [0.6966329, -1.089609e-08, -0.7174277]))),
];

#[rustfmt::skip]
const BLOB_SMOOTH: &[Row] = &[
    ([-2.0, 0.01943408, 0.5990184], [0.9842585, 0.1762211, -0.01346655], Some((2.336097, [0.2993233, 0.4311036, 0.5675593], [-0.6371166, -0.7594199, 0.1317718], [-0.6561362, -0.7497149, 0.08609831]))),
    ([3.5, 0.6141345, 1.038334], [-0.9751936, -0.05747046, -0.2137628], Some((2.511117, [1.051175, 0.4698195, 0.5015504], [0.7024155, -0.6791673, -0.2129417], [0.7329866, -0.6770639, -0.0656889]))),
    ([0.9039746, -0.06073924, -2.3], [-0.1117128, 0.2800393, 0.9534664], Some((2.549921, [0.6191157, 0.6533387, 0.1312639], [0.1801611, -0.185101, -0.9660639], [0.1808054, -0.1856226, -0.9658434]))),
    ([0.4052673, 1.319027, -2.3], [0.02441074, -0.2208008, 0.9750134], Some((2.469918, [0.4655598, 0.7736675, 0.1082034], [-0.06666952, 0.2467579, -0.9667812], [-0.1027142, 0.09075768, -0.9905618]))),
    ([-2.0, 0.9642173, 0.4435461], [0.9940487, -0.1079379, 0.014719], Some((2.176619, [0.1636652, 0.7292776, 0.4755838], [-0.9776506, -0.1588449, -0.1377228], [-0.9960392, 0.0161828, -0.08743064]))),
    ([0.3895806, 3.5, 0.80819], [0.2005667, -0.9795752, -0.01433084], Some((2.405605, [0.8720648, 1.143529, 0.7737157], [0.5868576, 0.6522098, 0.4798131], [0.5695698, 0.563022, 0.5988293]))),
    ([0.6579015, 0.9461262, -2.3], [0.04865457, -0.05829647, 0.997113], Some((2.456967, [0.7774442, 0.8028937, 0.1498737], [0.255201, -0.01184542, -0.9668155], [0.2596919, -0.04753146, -0.9645211]))),
    ([-0.07942694, -2.0, 0.9262276], [0.2142444, 0.9751702, -0.05605792], Some((2.481093, [0.4521334, 0.4194877, 0.7871426], [-0.3321092, -0.7620409, 0.5558753], [-0.3439266, -0.7300334, 0.5905638]))),
    ([0.7440146, 1.284406, 3.2], [0.1063306, -0.2492297, -0.9625894], Some((2.497681, [1.009594, 0.6619093, 0.7957587], [0.4498658, -0.2169427, 0.8663467], [0.5029973, -0.2310364, 0.832836]))),
    ([1.112686, 1.014832, -2.3], [-0.2153933, -0.04710463, 0.9753906], Some((2.485076, [0.577417, 0.8977733, 0.1239198], [0.02944755, 0.1329179, -0.9906896], [-0.0393027, 0.2079027, -0.9773596]))),
    ([3.5, 0.4898354, 0.6496552], [-0.9978947, 0.05981027, -0.02507651], Some((2.358423, [1.146542, 0.6308933, 0.5905142], [0.9436173, -0.2680345, 0.1942781], [0.9215711, -0.330337, 0.203922]))),
    ([0.5537095, 3.5, -0.3049537], [-0.004926535, -0.9521548, 0.3055764], Some((2.402585, [0.541873, 1.212367, 0.4292196], [-0.6226036, 0.7663758, -0.158218], [-0.5254959, 0.8246777, -0.2091906]))),
];

#[test]
fn sdfgrid_hits_and_normals_match_mitsuba() {
    let l = load("ts", "torus16.vol", "smooth", "");
    check("torus smooth", &l, TORUS_SMOOTH);
    let xf = r#"<transform name="to_world"><scale x="2" y="1.5" z="1"/><translate x="-1" y="0.2"/></transform>"#;
    let l = load("ta", "torus16.vol", "analytic", xf);
    assert!(
        l.warnings.iter().all(|w| !w.contains("sdfgrid")),
        "{:?}",
        l.warnings
    );
    check("torus analytic", &l, TORUS_ANALYTIC);
    let xf = r#"<transform name="to_world"><scale value="1.5"/><translate z="-0.3"/></transform>"#;
    check(
        "blob smooth",
        &load("bs", "blob.vol", "smooth", xf),
        BLOB_SMOOTH,
    );
}

#[test]
fn sdfgrid_warns_about_a_rotation_as_mitsuba() {
    let xf = r#"<transform name="to_world"><rotate y="1" angle="30"/></transform>"#;
    let l = load("rot", "torus16.vol", "smooth", xf);
    let n = l
        .warnings
        .iter()
        .filter(|w| w.contains("shouldn't perform any rotations"))
        .count();
    assert_eq!(n, 1, "{:?}", l.warnings);
}

/// The error of loading `body`, with its message.
fn error(name: &str, body: &str) -> String {
    match load_scene(&write_scene(name, body), &LoadOptions::default()) {
        Ok(_) => panic!("{name}: loaded"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn sdfgrid_errors_name_the_element_and_the_problem() {
    let dir = crate::common::Scratch::new(&format!("groove_sdf_{}_bad", std::process::id()));
    let good = std::fs::read(grid_file("torus16.vol")).unwrap();
    let bad = |name: &str, bytes: &[u8]| {
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        p.to_str().unwrap().to_string()
    };
    let mut wrong_version = good.clone();
    wrong_version[3] = 2;
    let mut two_channels = good.clone();
    two_channels[20] = 2;
    let mut all_positive = good[..48].to_vec();
    all_positive.extend((0..16 * 16 * 16).flat_map(|_| 1.0f32.to_le_bytes()));
    let mut nan = good.clone();
    nan[100..104].copy_from_slice(&f32::NAN.to_le_bytes());
    // 12 × 9 × 14: a sign change, but x and z sizes differ.
    let mut xz = good[..48].to_vec();
    xz[8..20]
        .copy_from_slice(&[12i32.to_le_bytes(), 9i32.to_le_bytes(), 14i32.to_le_bytes()].concat());
    xz.extend(
        (0..12 * 9 * 14).flat_map(|i| (if i % 2 == 0 { 1.0f32 } else { -1.0 }).to_le_bytes()),
    );
    let shape = |file: &str, extra: &str| {
        format!(r#"<shape type="sdfgrid"><string name="filename" value="{file}"/>{extra}</shape>"#)
    };
    let torus = grid_file("torus16.vol");
    for (name, body, msg) in [
        ("trunc", shape(&bad("t.vol", &good[..1000]), ""), "offset 48: 16x16x16 voxels of 1 channel(s) need 16384 bytes of values, the file has 952"),
        ("short", shape(&bad("s.vol", &good[..20]), ""), "truncated header"),
        ("magic", shape(&bad("m.vol", b"NOPE and more bytes than a header has, to be sure."), ""), "offset 0: not a Mitsuba volume file"),
        ("version", shape(&bad("v.vol", &wrong_version), ""), "offset 3: version 2"),
        ("channels", shape(&bad("c.vol", &two_channels), ""), "offset 48:"),
        ("empty", shape(&bad("e.vol", &all_positive), ""), "no voxel with a surface"),
        ("nan", shape(&bad("n.vol", &nan), ""), "non-finite values"),
        ("normals", shape(&torus, r#"<string name="normals" value="bogus"/>"#), "invalid normals mode \"bogus\""),
        ("flip", shape(&torus, r#"<boolean name="flip_normals" value="true"/>"#), "unreferenced property 'flip_normals'"),
        ("emitter", shape(&torus, r#"<emitter type="area"><rgb name="radiance" value="1"/></emitter>"#), "cannot carry an area emitter"),
        ("nofile", r#"<shape type="sdfgrid"/>"#.to_string(), "sdfgrid needs a 'filename'"),
        ("xz", shape(&bad("xz.vol", &xz), ""), "x size 12 and z size 14 is not supported"),
    ] {
        let e = error(name, &body);
        assert!(e.contains("scene.xml:3:"), "{name}: no location in {e}");
        assert!(e.contains(msg), "{name}: expected '{msg}' in: {e}");
    }
}
