use super::lay::plane_gradient;
use super::*;

#[test]
fn a_change_added_at_the_cells_centres_is_found_there() {
    let (w, h) = (12, 9);
    let values: Vec<f32> = (0..w * h).map(|i| 100.0 * ((i % w) as f32 / 2.0).sin() + (i / w) as f32 * 15.0).collect();
    let mut s = BaseSurface::from_grid(4, w, h, values.clone());
    let before = s.at_cell_centres();
    // the centre of coarse cell (x, y) is output cell (4x + 1.5, 4y + 1.5): between
    // the four output cells about it
    let at = |s: &BaseSurface, x: usize, y: usize| {
        let (gx, gy) = (4 * x + 1, 4 * y + 1);
        (s.at(gx, gy) + s.at(gx + 1, gy) + s.at(gx, gy + 1) + s.at(gx + 1, gy + 1)) / 4.0
    };
    for (x, y) in [(3, 3), (7, 4), (9, 6)] {
        assert!((before[y * w + x] - at(&s, x, y)).abs() < 2.0, "({x}, {y})");
    }
    let delta: Vec<f32> = (0..w * h).map(|i| if i == 4 * w + 6 { -120.0 } else { 0.0 }).collect();
    s.add_at_cell_centres(&delta);
    let after = s.at_cell_centres();
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let k = y * w + x;
            assert!((after[k] - before[k] - delta[k]).abs() < 0.5, "({x}, {y}): {} against {}", after[k] - before[k], delta[k]);
        }
    }
}

#[test]
fn a_surface_read_by_rows_has_the_bits_of_one_read_by_cells() {
    for (cell, w, h) in [(4, 12, 9), (1, 5, 7), (7, 3, 2)] {
        let values: Vec<f32> = (0..w * h).map(|i| 900.0 + 37.0 * ((i * 7 % 11) as f32).sin() - (i / w) as f32 * 3.3).collect();
        let s = BaseSurface::from_grid(cell, w, h, values);
        // past the grid's far edge too (clamped taps)
        let (cw, ch) = (w * cell + 5, h * cell + 3);
        let rows = s.rows(cw);
        for y in 0..ch {
            let row = rows.row(y);
            for x in 0..cw {
                assert_eq!(row(x).to_bits(), s.at(x, y).to_bits(), "cell {cell}, ({x}, {y})");
            }
        }
    }
}

fn canvas_with(w: usize, h: usize, patch: usize, f: impl Fn(usize, usize) -> f32) -> Canvas {
    let mut c = Canvas::new(w, h, patch);
    for y in 0..h {
        for x in 0..w {
            c.heights.data[y * w + x] = f(x, y);
        }
    }
    c.empty = c.heights.data.iter().filter(|v| v.is_nan()).count();
    c
}

#[test]
fn interpolates_between_two_levels_smoothly() {
    // known band at 100 on the left, at 500 on the right, a wide hole between
    let c = canvas_with(512, 128, 32, |x, _| {
        if x < 64 {
            100.0
        } else if x >= 448 {
            500.0
        } else {
            f32::NAN
        }
    });
    let b = BaseSurface::of(&c);
    // known parts keep their level
    assert!((b.at(10, 60) - 100.0).abs() < 1e-3);
    assert!((b.at(505, 60) - 500.0).abs() < 1e-3);
    // across the hole: monotone, no step larger than a few times the mean slope
    let row: Vec<f32> = (0..512).map(|x| b.at(x, 64)).collect();
    let mean_slope = 400.0 / 384.0;
    for x in 1..512 {
        let d = row[x] - row[x - 1];
        assert!(d >= -1e-3, "not monotone at {x}: {d}");
        assert!(d <= 3.0 * mean_slope, "step of {d} at {x}");
    }
    // the middle lies near the average of the two sides
    assert!((row[256] - 300.0).abs() < 40.0, "middle {}", row[256]);
}

#[test]
fn on_base_swaps_the_plane_and_keeps_the_relief() {
    let p = 16;
    let bump = |x: usize, y: usize| ((x as f32 - 7.5).powi(2) + (y as f32 - 7.5).powi(2)) * -0.5;
    // a tilted bump on a tilted base: the result is the base plus the bump about its mean
    let pixels: Vec<f32> = (0..p * p).map(|k| 300.0 + 9.0 * (k % p) as f32 - 4.0 * (k / p) as f32 + bump(k % p, k / p)).collect();
    let base: Vec<f32> = (0..p * p).map(|k| 1000.0 + 2.0 * (k / p) as f32).collect();
    let mean_bump = (0..p * p).map(|k| bump(k % p, k / p)).sum::<f32>() / (p * p) as f32;
    let out = on_base(&pixels, &base, false);
    for k in 0..p * p {
        let want = base[k] + bump(k % p, k / p) - mean_bump;
        assert!((out[k] - want).abs() < 1e-2, "cell {k}: {} vs {want}", out[k]);
    }
}

#[test]
fn a_valley_laid_on_a_target_falling_its_way_keeps_its_fall_and_drains() {
    use crate::solvers::hydrology::water_levels;
    use ridgeline_terrain::grid::Heightfield;
    let p = 32;
    // a real valley's long profile is concave (steep at its head, gentle at its
    // mouth): 400 m down along x, with V-shaped sides
    let valley = |x: usize, y: usize| {
        let u = x as f32 / (p - 1) as f32;
        400.0 * (1.0 - u).powi(2) + 6.0 * (y as f32 - 15.5).abs()
    };
    let pixels: Vec<f32> = (0..p * p).map(|k| valley(k % p, k / p)).collect();
    // targets falling or rising along x by so many metres a cell
    let target = |fall: f32| (0..p * p).map(|k| 1000.0 - fall * (k % p) as f32).collect::<Vec<f32>>();
    let deepest_pit = |laid: &[f32]| {
        let h = Heightfield::from_vec(p, p, laid.to_vec());
        water_levels(&h).iter().zip(laid).map(|(w, z)| w - z).fold(0f32, f32::max)
    };
    // its best-fit plane replaced by the target, the floor's middle lies below both
    // ends: a pit tens of metres deep
    let falling = target(5.0);
    let plane_only = on_base(&pixels, &falling, false);
    assert!(deepest_pit(&plane_only) > 20.0, "{}", deepest_pit(&plane_only));
    // keeping its fall along the target's way down, it drains
    let kept = on_base(&pixels, &falling, true);
    assert!(deepest_pit(&kept) < 1e-3, "{}", deepest_pit(&kept));
    // its relief about its plane and its mean level are the same either way
    let mean = |v: &[f32]| v.iter().map(|&z| z as f64).sum::<f64>() / v.len() as f64;
    assert!((mean(&kept) - mean(&plane_only)).abs() < 1e-2);
    // on a gentler target it keeps at most three times the target's own fall (the
    // valley's plane falls 12.9 m a cell)
    let (tx, ty) = downstream_tilt(plane_gradient(&pixels), &target(1.0));
    assert!((tx + FALL_CAP_SLOPES).abs() < 1e-3 && ty.abs() < 1e-3, "{tx} {ty}");
    // on a target rising that way, nothing of its fall is kept
    let rising = target(-1.0);
    assert_eq!(on_base(&pixels, &rising, true), on_base(&pixels, &rising, false));
    // nor on a level one
    let level = target(0.0);
    assert_eq!(on_base(&pixels, &level, true), on_base(&pixels, &level, false));
}

#[test]
fn a_coarse_terrain_keeps_only_the_patch_detail_below_its_scale() {
    let p = 64;
    // a wide bump (the patch's own large form) and a short wave (period 6) on a tilt
    let long = |x: usize| 300.0 * (x as f32 * std::f32::consts::TAU / 200.0).cos();
    let short = |x: usize| 10.0 * (x as f32 * std::f32::consts::TAU / 6.0).sin();
    let pixels: Vec<f32> = (0..p * p).map(|k| 5.0 * (k / p) as f32 + long(k % p) + short(k % p)).collect();
    let surface = BaseSurface::coarse_terrain(4, 32, 32, vec![1000.0; 32 * 32], CoarseBand::Blurred(DETAIL_BAND));
    let out = surface.lay(&pixels, &vec![1000.0; p * p]);
    // the short wave on the base, the bump and the tilt gone: what is left besides
    // the short wave varies by a small part of the bump's 300 m (one-sided taps
    // near the patch's edges leave some)
    let rest: Vec<f32> = (0..p * p).map(|k| out[k] - 1000.0 - short(k % p)).collect();
    let (lo, hi) = rest.iter().fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    assert!(hi - lo < 45.0, "left besides the short wave: {lo}..{hi}");
    let mean = rest.iter().sum::<f32>() / rest.len() as f32;
    let centre = (16..48).flat_map(|y| (16..48).map(move |x| y * p + x));
    assert!(centre.clone().all(|k| (rest[k] - mean).abs() < 15.0), "the centre keeps the short wave");
    // a smooth target keeps the whole relief about the plane instead
    let target = BaseSurface::from_grid(4, 32, 32, vec![1000.0; 32 * 32]);
    let kept = target.lay(&pixels, &vec![1000.0; p * p]);
    let amp = (16..48).map(|x| (kept[32 * p + x] - 1000.0).abs()).fold(0f32, f32::max);
    assert!(amp > 30.0, "the bump stays on a smooth target: {amp}");
}

/// A wave's gain through the coarse surface (its values sampled on the coarse
/// grid) and through a patch laid on it: their powers add up to about one at
/// every wavelength across the band between the levels, as two independent
/// windows' bands must for the output to keep its sources' spectrum. (Cut at
/// the band's σ itself, as before `DETAIL_KEPT_BANDS`, the sums at periods 16, 24,
/// 32 and 40 were 0.98, 0.81, 0.59 and 0.49; cut at twice, 1.04, 1.06, 1.24, 0.88.)
#[test]
fn the_two_bands_add_up_in_power_across_the_cut() {
    let (p, f, n) = (64usize, 4usize, 64usize);
    let tau = std::f32::consts::TAU;
    // amplitude of the wave of `period` along `xs` of a row `v(x)`, by projection
    let gain = |v: &dyn Fn(usize) -> f32, xs: std::ops::Range<usize>, period: f32| {
        let (mut a, mut b, mut m) = (0f32, 0f32, 0f32);
        for x in xs.clone() {
            let t = x as f32 * tau / period;
            a += v(x) * t.sin();
            b += v(x) * t.cos();
            m += 1.0;
        }
        2.0 * (a * a + b * b).sqrt() / m
    };
    let mut sums = Vec::new();
    for period in [16.0f32, 24.0, 32.0, 40.0] {
        // coarse cell i covers output cells 4i..4i+4: its value the wave at its centre
        let values: Vec<f32> = (0..n * n).map(|k| ((f * (k % n)) as f32 + 1.5) * tau / period).map(f32::sin).collect();
        let coarse = BaseSurface::coarse_terrain(f, n, n, values, CoarseBand::Blurred(DETAIL_BAND));
        let c = gain(&|x| coarse.at(x, n * f / 2), 64..192, period);
        let pixels: Vec<f32> = (0..p * p).map(|k| ((k % p) as f32 * tau / period).sin()).collect();
        let laid = coarse.lay(&pixels, &vec![0.0; p * p]);
        // one whole period about the patch's centre (the blur's taps are whole there)
        let half = period as usize / 2;
        let d = gain(&|x| laid[32 * p + x], 32 - half..32 + half, period);
        sums.push((period, c, d, c * c + d * d));
    }
    assert!(sums.iter().all(|s| (0.8..1.3).contains(&s.3)), "gains (period, coarse, patch, power): {sums:?}");
}

#[test]
fn an_interpolated_coarse_terrain_passes_through_its_cells_values() {
    // rough values on a 24 x 20 grid, three output cells a coarse cell
    let (cw, ch) = (24, 20);
    let values: Vec<f32> = (0..cw * ch).map(|i| ((i * 7919) % 97) as f32 * 10.0).collect();
    let exact = BaseSurface::coarse_terrain(3, cw, ch, values.clone(), CoarseBand::Interpolated(0.375));
    let blurred = BaseSurface::coarse_terrain(3, cw, ch, values.clone(), CoarseBand::Blurred(DETAIL_BAND));
    let (mut worst, mut blur_err) = (0f32, 0f32);
    for j in 3..ch - 3 {
        for i in 3..cw - 3 {
            // the output cell at a coarse cell's centre
            let (x, y) = (3 * i + 1, 3 * j + 1);
            worst = worst.max((exact.at(x, y) - values[j * cw + i]).abs());
            blur_err = blur_err.max((blurred.at(x, y) - values[j * cw + i]).abs());
        }
    }
    assert!(worst < 0.5, "the interpolated surface is {worst} m off a cell's value");
    assert!(blur_err > 100.0, "the blurred one smooths them ({blur_err} m)");
}

#[test]
fn empty_canvas_gives_a_flat_base() {
    let c = canvas_with(100, 70, 16, |_, _| f32::NAN);
    let b = BaseSurface::of(&c);
    assert!((0..100).all(|x| b.at(x, 35) == 0.0));
}

#[test]
fn patch_matches_pointwise_values() {
    let c = canvas_with(200, 150, 32, |x, y| if x + y < 120 { (x * 2 + y) as f32 } else { f32::NAN });
    let b = BaseSurface::of(&c);
    let win = Win::new(20, 100, 32, 200, 150); // clipped on the left
    let p = b.patch(&win, (0, 0));
    for j in 0..win.h {
        for i in 0..win.w {
            let (gx, gy) = (win.x0 + i, win.y0 + j);
            assert_eq!(p[(win.py + j) * 32 + win.px + i], b.at(gx, gy));
        }
    }
}
