//! The `moment` and `aov` integrators against Mitsuba 3.9.1 (`tests/refs/moment.*`,
//! `tests/refs/aov.*`, made by `tests/refs/make_refs.py`): the channel names, the RGB image and
//! every extra channel, by the per-tile z-tests of `common::imgcmp` with both sides' noise (the
//! geometric AOVs are pixel averages over the box filter's footprint, so they carry sampling noise
//! too, and are exact, noise-free, on pixels of one flat surface or of the background).

use crate::common;

use common::{compare, load_reference, repo_root, test_scene, RgbImage};
use groove::output::read_exr_channels;

/// Groove's render of `scene` with its film: (channel names, film).
fn render(scene: &str, spp: u32, seed: u64) -> (Vec<String>, groove::film::Film) {
    let path = test_scene(scene);
    let loaded = groove::load::load_scene(&path, &Default::default())
        .unwrap_or_else(|e| panic!("loading {scene}: {e}"));
    let ro = groove::render::RenderOptions {
        spp: Some(spp),
        seed: Some(seed),
        renderer: crate::common::renderer(),
        ..Default::default()
    };
    let out = groove::render::render(&loaded.scene, &loaded.settings, &ro).expect("render");
    (loaded.settings.integrator.aov_names(), out.film)
}

/// Up to three named channels packed as one test image (missing slots stay 0).
fn pack(w: u32, h: u32, chans: &[&[f32]]) -> RgbImage {
    let mut img = RgbImage::new(w as usize, h as usize);
    for (c, v) in chans.iter().enumerate() {
        for (p, &x) in img.data.iter_mut().zip(v.iter()) {
            p[c] = x as f64;
        }
    }
    img
}

/// The reference's channels by name: (width, height, mean, variance of the mean).
struct RefChannels {
    w: u32,
    h: u32,
    mean: Vec<(String, Vec<f32>)>,
    var: Vec<(String, Vec<f32>)>,
}

impl RefChannels {
    fn load(name: &str) -> RefChannels {
        let dir = repo_root().join("tests").join("refs");
        let (w, h, mean) = read_exr_channels(&dir.join(format!("{name}.channels.exr"))).unwrap();
        let (_, _, var) = read_exr_channels(&dir.join(format!("{name}.channels.var.exr"))).unwrap();
        RefChannels { w, h, mean, var }
    }
    fn names(&self) -> Vec<String> {
        self.mean.iter().map(|(n, _)| n.clone()).collect()
    }
    fn get<'a>(list: &'a [(String, Vec<f32>)], name: &str) -> &'a [f32] {
        &list
            .iter()
            .find(|(n, _)| n == name)
            .unwrap_or_else(|| panic!("the reference has no channel {name}"))
            .1
    }
}

/// Pixels the reference has without noise (variance 0: the background, flat surfaces' normals,
/// a directly seen constant sky) are compared here, to 1e-4 relative plus 1e-6 absolute, and
/// then taken out of the statistical test (set to the reference on both sides): float32
/// accumulation in Mitsuba's film (a sky of 1.0887540 sums to 1.088812 over 16384 samples) and
/// transforms built in double (a rotated normal's 6e-17 against groove's float -4e-8) differ by
/// more than the harness's exact-tile tolerance of 1e-5 relative, with no noise to absorb it.
fn settle_exact(
    test: &mut [f32],
    test_var: &mut [f32],
    reference: &[f32],
    ref_var: &[f32],
    what: &str,
) {
    for i in 0..reference.len() {
        if ref_var[i] > 0.0 {
            continue;
        }
        let (t, r) = (test[i], reference[i]);
        assert!(
            (t - r).abs() <= 1e-4 * r.abs() + 1e-6,
            "{what}: pixel {i} is noise-free in the reference ({r}), groove has {t}"
        );
        test[i] = r;
        test_var[i] = 0.0;
    }
}

/// Compares every extra channel of `film` (named `names`) with the reference, in groups of up
/// to three, and the RGB image with `NAME.exr`.
/// Pixels for which `skip(channel, pixel)` holds are left out (both sides set to the reference).
fn check_channels(
    names: &[String],
    film: &groove::film::Film,
    reference: &str,
    block: usize,
    skip: &dyn Fn(&str, usize) -> bool,
) {
    let r = RefChannels::load(reference);
    let mut ref_names = r.names();
    ref_names.retain(|n| !["R", "G", "B"].contains(&n.as_str()));
    let mut ours = names.to_vec();
    ours.sort();
    assert_eq!(ours, ref_names, "channel names differ from Mitsuba's");

    let to_rgb = |img: &groove::film::Image| {
        let mut out = RgbImage::new(img.width as usize, img.height as usize);
        for (o, p) in out.data.iter_mut().zip(&img.data) {
            *o = p.map(|v| v as f64);
        }
        out
    };
    let (m, v) = load_reference(reference);
    compare(
        &to_rgb(&film.develop()),
        &to_rgb(&film.develop_variance().expect("second moments")),
        &m,
        &v,
        block,
    )
    .assert_consistent(&format!("{reference}: RGB image"));

    for group in names.chunks(3) {
        let idx: Vec<usize> = group
            .iter()
            .map(|g| names.iter().position(|n| n == g).unwrap())
            .collect();
        let mut ours: Vec<Vec<f32>> = idx.iter().map(|&c| film.develop_channel(c)).collect();
        let mut ours_var: Vec<Vec<f32>> = idx
            .iter()
            .map(|&c| film.develop_channel_variance(c).expect("second moments"))
            .collect();
        let refm: Vec<&[f32]> = group.iter().map(|g| RefChannels::get(&r.mean, g)).collect();
        let refv: Vec<&[f32]> = group.iter().map(|g| RefChannels::get(&r.var, g)).collect();
        // Float rounding of the geometric quantities (transforms in double on Mitsuba's side)
        // as a variance floor: (2e-6 of the channel's largest magnitude)² on both sides of
        // pixels with noise, so that components that are 0 up to rounding (1e-8 against 1e-17)
        // are not read as significant differences. Pixels without noise are settled exactly.
        let mut refv_floor: Vec<Vec<f32>> = refv.iter().map(|v| v.to_vec()).collect();
        for k in 0..group.len() {
            for i in 0..ours[k].len() {
                if skip(&group[k], i) {
                    ours[k][i] = refm[k][i];
                    ours_var[k][i] = refv[k][i];
                }
            }
            settle_exact(&mut ours[k], &mut ours_var[k], refm[k], refv[k], &group[k]);
            let scale = refm[k].iter().fold(0.0f32, |a, &v| a.max(v.abs()));
            let floor = (2e-6 * scale).powi(2);
            for (i, rv) in refv_floor[k].iter_mut().enumerate() {
                if *rv > 0.0 {
                    *rv += floor;
                    ours_var[k][i] += floor;
                }
            }
        }
        let refv: Vec<&[f32]> = refv_floor.iter().map(|v| v.as_slice()).collect();
        let ours: Vec<&[f32]> = ours.iter().map(|v| v.as_slice()).collect();
        let ours_var: Vec<&[f32]> = ours_var.iter().map(|v| v.as_slice()).collect();
        let c = compare(
            &pack(r.w, r.h, &ours),
            &pack(r.w, r.h, &ours_var),
            &pack(r.w, r.h, &refm),
            &pack(r.w, r.h, &refv),
            block,
        );
        c.assert_consistent(&format!("{reference}: channels {group:?}"));
    }
}

#[test]
fn moment_channels_match_mitsuba() {
    let (names, film) = render("moment.xml", 1024, 11);
    assert_eq!(
        names,
        [
            "pt.X",
            "pt.Y",
            "pt.Z",
            "_arg_0.X",
            "_arg_0.Y",
            "_arg_0.Z",
            "m2_pt.X",
            "m2_pt.Y",
            "m2_pt.Z",
            "m2__arg_0.X",
            "m2__arg_0.Y",
            "m2__arg_0.Z"
        ]
    );
    check_channels(&names, &film, "moment", 4, &|_, _| false);
    // The image is the inner path estimate: the plain path reference of the same scene applies.
    let (m, v) = load_reference("depth_sphere_d3");
    let img = film.develop();
    let var = film.develop_variance().expect("second moments");
    let rgb = |i: &groove::film::Image| {
        pack(
            i.width,
            i.height,
            &[
                &i.data.iter().map(|p| p[0]).collect::<Vec<_>>(),
                &i.data.iter().map(|p| p[1]).collect::<Vec<_>>(),
                &i.data.iter().map(|p| p[2]).collect::<Vec<_>>(),
            ],
        )
    };
    compare(&rgb(&img), &rgb(&var), &m, &v, 4).assert_consistent("moment image vs path reference");
}

#[test]
fn aov_channels_match_mitsuba() {
    let (names, film) = render("aov.xml", 512, 12);
    // prim_index is compared on the meshes only: on the analytic floor rectangle Mitsuba 3.9.1
    // reports 0 or 1 by region (groove: 0). The rectangle is shape 4 (the first in the file);
    // only pixels that see one mesh (or the background) throughout are compared.
    let r = RefChannels::load("aov");
    let si = RefChannels::get(&r.mean, "si.I").to_vec();
    let si_var = RefChannels::get(&r.var, "si.I").to_vec();
    let one_mesh = |i: usize| si_var[i] == 0.0 && si[i] < 3.5;
    let skip = |name: &str, i: usize| name == "pi.I" && !one_mesh(i);
    check_channels(&names, &film, "aov", 4, &skip);
}

#[test]
fn aov_channels_are_written_to_exr_by_name_and_dropped_from_png() {
    let (names, film) = render("aov.xml", 4, 13);
    let dir = crate::common::Scratch::new(&format!("groove-aov-{}", std::process::id()));
    let extra: Vec<(String, Vec<f32>)> = names
        .iter()
        .enumerate()
        .map(|(c, n)| (n.clone(), film.develop_channel(c)))
        .collect();
    let img = film.develop();
    let meta = groove::output::Metadata::default();
    let exr = dir.join("aov.exr");
    assert!(groove::output::write_image_channels(&exr, &img, &extra, &meta).unwrap());
    let (w, h, chans) = read_exr_channels(&exr).unwrap();
    assert_eq!((w, h), (img.width, img.height));
    let mut want: Vec<String> = names.clone();
    want.extend(["R", "G", "B"].map(String::from));
    want.sort();
    let got: Vec<String> = chans.iter().map(|(n, _)| n.clone()).collect();
    assert_eq!(got, want);
    for (n, v) in &chans {
        if let Some((_, e)) = extra.iter().find(|(en, _)| en == n) {
            assert_eq!(v, e, "channel {n} round trip");
        }
    }
    let png = dir.join("aov.png");
    assert!(!groove::output::write_image_channels(&png, &img, &extra, &meta).unwrap());
    assert!(png.is_file());
}

#[test]
fn aov_shape_index_and_normals_under_instancing_match_mitsuba() {
    // Mitsuba numbers the sphere 1, the instances 2 and 3 (every hit through one reports it),
    // the disk 4 and the floor, the only mesh, 5; the second instance's normals follow its
    // non-unit <rotate> axis's raw matrix (tests/data/scenes/aov_instance.xml).
    let (names, film) = render("aov_instance.xml", 512, 14);
    check_channels(&names, &film, "aov_instance", 4, &|_, _| false);
}
