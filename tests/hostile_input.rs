//! Synthesis on libraries built to be awkward: exemplars with voids, and a library
//! that offers no ridges at all for a sketch that asks for one.

use ridgeline::evaluation::quality::adherence;
use ridgeline_terrain::grid::Grid;
use ridgeline_terrain::outputs::write_heightfield_with_cell;
use ridgeline_terrain::FeatureKind;
use ridgeline_tests::{session, temp_dir};
use std::path::Path;

fn noise(x: usize, y: usize) -> f32 {
    let h = (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
    ((h >> 40) % 1000) as f32 / 1000.0
}

fn sketch(path: &Path, ridge: bool) {
    let img = image::GrayImage::from_fn(160, 128, |x, y| {
        let on = (y as i32 - 64 - (x as i32 - 80) / 6).abs() <= 2 && (16..144).contains(&x);
        image::Luma([if on {
            if ridge {
                255
            } else {
                0
            }
        } else {
            128
        }])
    });
    img.save(path).unwrap();
}

#[test]
fn voids_in_exemplars_never_reach_the_output() {
    let d = temp_dir("voids");
    let lib = d.join("lib");
    std::fs::create_dir_all(&lib).unwrap();
    // a rough hilly terrain with a 70 x 70 void, written as float TIFF with NaN
    let (w, h) = (320, 300);
    let mut t = Grid::new(w, h, 0f32);
    for y in 0..h {
        for x in 0..w {
            let v = 400.0 * ((x as f32) * 0.045).sin() * ((y as f32) * 0.03).cos()
                + 120.0 * ((x + 2 * y) as f32 * 0.11).sin()
                + 20.0 * noise(x, y);
            t.set(x, y, if (120..190).contains(&x) && (110..180).contains(&y) { f32::NAN } else { 1000.0 + v });
        }
    }
    write_heightfield_with_cell(&lib.join("holey.tif"), &t, Some(90.0)).unwrap();
    let sk = d.join("sketch.png");
    sketch(&sk, true);
    let out = session(&sk, &lib, &d.join("cache")).patch_size(32).build().and_then(|s| s.run()).expect("synthesis");
    assert!(out.terrain().data.iter().all(|v| v.is_finite()), "a void was copied into the output");
    assert!(out.report.user_patches[FeatureKind::Ridge] > 0 && out.report.placement.placed > 0);
}

#[test]
fn a_ridge_with_no_ridge_in_the_library_falls_back_to_inverted_valleys() {
    let d = temp_dir("fallback");
    let lib = d.join("lib");
    std::fs::create_dir_all(&lib).unwrap();
    // one long V-shaped valley: no ridge anywhere
    let (w, h) = (320, 320);
    let t = Grid::from_vec(
        w,
        h,
        (0..w * h).map(|i| 500.0 + 12.0 * ((i % w) as f32 - 160.0).abs() + 2.0 * noise(i % w, i / w)).collect(),
    );
    write_heightfield_with_cell(&lib.join("valley.tif"), &t, Some(90.0)).unwrap();
    let sk = d.join("sketch.png");
    sketch(&sk, true);
    let out = session(&sk, &lib, &d.join("cache")).patch_size(32).build().and_then(|s| s.run()).expect("synthesis");
    assert_eq!(out.report.exemplars[0].feature_nodes[FeatureKind::Ridge], 0, "the library has no ridge candidates");
    assert!(!out.report.placement.fallbacks.is_empty(), "the fallback is reported");
    assert!(out.report.placement.fallbacks[0].contains("ridge"), "{:?}", out.report.placement.fallbacks);
    assert!(out.terrain().data.iter().all(|v| v.is_finite()));
    let a = adherence(
        out.terrain(),
        out.output.sketch.graph(FeatureKind::Ridge),
        FeatureKind::Ridge,
        8.0,
        4,
        8,
        &out.output.sketch.bounds(),
    );
    assert!(a.fraction() >= 0.8, "inverted valleys make a ridge: {} of {}", a.matching, a.sampled);
}
