//! Each figure separates what it should: a crop of a real DEM scores as real against
//! its DEM; a blurred crop and a hard-seamed quilt of patches score worse; a strongly
//! repeated patch is caught.

use super::*;
use ridgeline_terrain::grid::Grid;

fn shared_dem(name: &str) -> Option<Heightfield> {
    let p = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/dems").join(name);
    if !p.is_file() {
        eprintln!("SKIPPED: {} not found", p.display());
        return None;
    }
    let g = ridgeline_terrain::io::read_dem_png(&p, 8192).ok()?;
    Some(Grid::from_vec(g.width, g.height, g.data.iter().map(|v| v * 0.3048).collect()))
}

fn crop(h: &Heightfield, x0: usize, y0: usize, w: usize) -> Heightfield {
    Grid::from_vec(w, w, (0..w * w).map(|i| h.get(x0 + i % w, y0 + i / w)).collect())
}

/// A provenance cutting the terrain into `patch` squares, placement k from (sx, sy).
fn grid_provenance(w: usize, patch: usize, name: &str, src: impl Fn(usize) -> (u32, u32)) -> Provenance {
    let per_row = w.div_ceil(patch);
    let cells = (0..w * w).map(|i| ((i / w / patch) * per_row + (i % w) / patch) as u32).collect();
    let placements = (0..per_row * per_row)
        .map(|k| {
            let (src_x, src_y) = src(k);
            PlacedPatch {
                exemplar: name.into(),
                src_x,
                src_y,
                cx: (k % per_row) * patch + patch / 2,
                cy: (k / per_row) * patch + patch / 2,
                variant: 0,
            }
        })
        .collect();
    Provenance { cells, placements }
}

fn eval(terrain: &Heightfield, source: &Heightfield, prov: Option<&Provenance>) -> Evaluation {
    let sources = source_figures::of_heights(&[("dem.png".to_string(), source.clone())], 90.0);
    evaluate(&Inputs { terrain, cell_m: 90.0, sketch: None, patch: 64, sources: &sources, provenance: prov })
}

#[test]
fn a_real_crop_scores_as_real_and_a_blurred_one_does_not() {
    let Some(dem) = shared_dem("rockies.png") else { return };
    let real = crop(&dem, (dem.width - 384) / 2, (dem.height - 384) / 2, 384);
    let e = eval(&real, &dem, None);
    assert!(e.landform_distance < 0.15, "landform distance {}", e.landform_distance);
    let d = e.spectral_slope_difference.unwrap();
    assert!(d.abs() < 0.35, "slope difference {d}");
    let r = e.roughness_ratio.unwrap();
    assert!((0.75..1.33).contains(&r), "roughness ratio {r}");
    let blur = box_blur(&real, 2);
    let b = eval(&blur, &dem, None);
    assert!(b.roughness_ratio.unwrap() < 0.5 * r, "blurred roughness {} vs {r}", b.roughness_ratio.unwrap());
    assert!(b.spectral_slope_difference.unwrap() < d - 0.3, "blurred slope {}", b.spectral_slope_difference.unwrap());
    assert!(b.landform_distance > e.landform_distance, "blurred landforms {} vs {}", b.landform_distance, e.landform_distance);
}

#[test]
fn a_hard_seamed_quilt_scores_worse_than_a_real_crop() {
    let Some(dem) = shared_dem("rockies.png") else { return };
    let (w, patch) = (512, 64);
    let real = crop(&dem, 60, 60, w);
    // the same cut, all from one continuous crop: seams are only nominal
    let nominal = grid_provenance(w, patch, "dem.png", |k| (60 + (k % 8) as u32 * 64, 60 + (k / 8) as u32 * 64));
    let e = eval(&real, &dem, Some(&nominal));
    let real_seams = e.seams.unwrap().mean_ratio;
    assert!(real_seams < 1.3, "a real DEM's seam ratio {real_seams}");
    // patches from scattered places, pasted side by side
    let mut quilt = real.clone();
    // 64 windows 70 cells apart, in a scrambled order
    let spots = |k: usize| {
        let j = (k * 37) % 64;
        (8 + (j % 8) * 70, 8 + (j / 8) * 70)
    };
    for k in 0..64 {
        let (sx, sy) = spots(k);
        for y in 0..patch {
            for x in 0..patch {
                quilt.set((k % 8) * patch + x, (k / 8) * patch + y, dem.get(sx + x, sy + y));
            }
        }
    }
    let prov = grid_provenance(w, patch, "dem.png", |k| (spots(k).0 as u32, spots(k).1 as u32));
    let q = eval(&quilt, &dem, Some(&prov));
    let s = q.seams.unwrap();
    assert!(s.mean_ratio > 3.0 * real_seams, "quilt seam ratio {} vs real {real_seams}", s.mean_ratio);
    assert!(q.repetition.unwrap() < 0.05, "scattered patches are not repeats");
}

#[test]
fn a_repeated_patch_is_caught() {
    // 8 x 8 placements of 64 cells; every placement copies one of two source windows
    let w = 512;
    let prov = grid_provenance(w, 64, "dem.png", |k| if k % 2 == 0 { (300, 300) } else { (900, 300) });
    let r = repetition(&prov, 64);
    assert!(r > 0.9, "repetition {r}");
    // all distinct windows: none
    let distinct = grid_provenance(w, 64, "dem.png", |k| (100 + 70 * k as u32, 100));
    assert_eq!(repetition(&distinct, 64), 0.0);
    // the same window far apart (beyond the radius) is not a repeat
    let far = Provenance {
        cells: vec![0, 1],
        placements: vec![
            PlacedPatch { exemplar: "a".into(), src_x: 50, src_y: 50, cx: 0, cy: 0, variant: 0 },
            PlacedPatch { exemplar: "a".into(), src_x: 50, src_y: 50, cx: 64 * 10, cy: 0, variant: 0 },
        ],
    };
    assert_eq!(repetition(&far, 64), 0.0);
    // ... nor is the same window of another source
    let other = Provenance {
        cells: vec![0, 1],
        placements: vec![
            PlacedPatch { exemplar: "a".into(), src_x: 50, src_y: 50, cx: 0, cy: 0, variant: 0 },
            PlacedPatch { exemplar: "b".into(), src_x: 50, src_y: 50, cx: 64, cy: 0, variant: 0 },
        ],
    };
    assert_eq!(repetition(&other, 64), 0.0);
}

#[test]
fn windows_that_continue_one_source_region_are_no_repeat() {
    use ridgeline_terrain::patch_geometry::Variant;
    // placements every quarter patch, each the window of one source region (rotated by
    // 90°: variant 2) at the offset it lies at in the output, as the windows that
    // continue a coarse placement are: overlapping windows, nothing shown twice
    let (w, patch) = (256usize, 64usize);
    let continued = |variant: u8, recorded: u8| {
        let mut prov = grid_provenance(w, patch / 4, "dem.png", |_| (0, 0));
        for p in &mut prov.placements {
            let (sx, sy) = Variant(variant).inverse(p.cx as f32 - 128.0, p.cy as f32 - 128.0);
            (p.src_x, p.src_y, p.variant) = ((300.0 + sx).round() as u32, (300.0 + sy).round() as u32, recorded);
        }
        repetition(&prov, patch)
    };
    assert_eq!(continued(2, 2), 0.0);
    assert_eq!(continued(0, 0), 0.0);
    // the same windows taken as another variant's copy: repeats
    assert!(continued(2, 0) > 0.5, "{}", continued(2, 0));
}
