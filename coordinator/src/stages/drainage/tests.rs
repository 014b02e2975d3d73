//! Breaching: known answers on small made-up terrains.

use super::search::{local_depth, pits};
use super::topology::Topology;
use super::*;
use crate::solvers::hydrology::{drainage_shares, water_levels};
use ridgeline_terrain::grid::Grid;

/// Floors alone, no ceilings, for `breach_depressions`.
fn floors(floor: &[f32]) -> SketchFloors {
    floor.to_vec().into()
}

/// A valley falling to the left border, dammed by a 30 m bar at x = 50.
fn dammed() -> Heightfield {
    let (w, h) = (120usize, 60usize);
    Grid::from_vec(
        w,
        h,
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                let valley = 200.0 + 0.8 * x + 4.0 * (y - 30.0).abs();
                let dam = if (x - 50.0).abs() < 2.0 { 30.0 } else { 0.0 };
                valley + dam
            })
            .collect(),
    )
}

#[test]
fn a_dammed_valley_is_breached_through_the_dam_with_few_cells() {
    let mut h = dammed();
    let before = h.clone();
    let sunk = drainage_shares(&h, SINK_DEPTH_M).sink_share;
    assert!(sunk > 0.01, "the dam holds a lake");
    let keep = vec![f32::NEG_INFINITY; h.data.len()];
    let s = breach_depressions(&mut h, &floors(&keep), 32, Hybrid::FillThenBreach);
    // the closed cells before it are the evaluation's sink share of the terrain before
    assert_eq!(s.cells_sunk_before, (sunk * h.data.len() as f64).round() as usize, "{s:?}");
    assert_eq!((s.depressions, s.left), (1, 0), "{s:?}");
    assert!(s.breached >= 1 && s.cells_lowered <= 150, "a short gully through the 3-cell dam, 2% of the cells: {s:?}");
    // the 30 m dam is cut by more than 10 m at its crest, its gully's flanks by less
    assert!(s.cells_lowered_over_10m > 0 && s.cells_lowered_over_10m < s.cells_lowered, "{s:?}");
    assert_eq!(drainage_shares(&h, MIN_DEPTH_M).sink_share, 0.0, "nothing closed is left");
    // lowered only near the dam (the gully starts from the lake's filled bottom, at
    // most the fill's side upstream of the pit beside the dam); raised only that
    // bottom, a few cells by less than the lake is deep
    let mut raised = 0;
    let side = (fill_cells(32) as f64).sqrt() as i64;
    for (i, (a, b)) in h.data.iter().zip(&before.data).enumerate() {
        if a < b {
            assert!(((i % 120) as i64 - 50).abs() <= 3 + side + OUTPUT_GULLY_RADIUS as i64, "cell {} lowered", i % 120);
        }
        if a > b {
            assert!(a - b < 30.0, "cell {i} raised by {}", a - b);
            raised += 1;
        }
    }
    // (a raised cell the gully then crosses may end lower)
    assert!(raised <= s.cells_raised && s.cells_raised <= fill_cells(32), "{raised} cells raised: {s:?}");
    // against filling the lake flat: the flooded cells and their depths, as counted
    let level = water_levels(&before);
    let flooded: Vec<f32> = level.iter().zip(&before.data).map(|(l, v)| l - v).filter(|&d| d > 0.0).collect();
    assert_eq!(s.fill_alternative_cells, flooded.len(), "{s:?}");
    let volume: f64 = flooded.iter().map(|&d| f64::from(d)).sum();
    assert!((s.fill_alternative_volume - volume).abs() <= 1e-6 * volume, "{volume} against {s:?}");
    // the volumes are what moved: every change is a fill's rise or a gully's cut
    let net: f64 = h.data.iter().zip(&before.data).map(|(a, b)| f64::from(a - b)).sum();
    assert!((net - (s.volume_raised - s.volume_lowered)).abs() < 0.5, "{net} moved: {s:?}");
    // and a fraction of what the fill would have (86 cells against 275, 754 m·cells
    // against 2,726): fewer cells, smaller changes
    assert!(s.cells_lowered + s.cells_raised < s.fill_alternative_cells / 2, "{s:?}");
    assert!(s.volume_lowered + s.volume_raised < s.fill_alternative_volume / 3.0, "{s:?}");
}

/// A hole 3 cells across and 600 m deep sunk in a plateau (tilted 0.01 m a cell)
/// 40 cells from its rim, beyond which the ground falls 10 m a cell.
fn hole_in_a_plateau() -> Heightfield {
    let (w, hh) = (120usize, 120usize);
    let plateau = |x: f32, y: f32| {
        let rim = (x - 60.0).abs().max((y - 60.0).abs());
        if rim < 40.0 {
            1500.0
        } else {
            1500.0 - 10.0 * (rim - 40.0)
        }
    };
    Grid::from_vec(
        w,
        hh,
        (0..w * hh)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                let hole = (x - 60.0).abs() <= 1.0 && (y - 60.0).abs() <= 1.0;
                plateau(x, y) + 0.01 * (x + y) - if hole { 600.0 } else { 0.0 }
            })
            .collect(),
    )
}

#[test]
fn a_trench_gives_way_to_a_larger_filled_bottom() {
    // at the output level the hole's 4-cell bottom is filled first, and the breach
    // from there would be a trench 40 cells long cutting hundreds of metres; filled
    // with the plateau cells beside it (64 cells), the breach from its floor runs
    // down the plateau's tilt and cuts almost nothing
    let mut h = hole_in_a_plateau();
    let before = h.clone();
    let keep = vec![f32::NEG_INFINITY; h.data.len()];
    let s = breach_depressions(&mut h, &floors(&keep), 32, Hybrid::FillThenBreach);
    assert_eq!(s.left, 0, "{s:?}");
    assert!(s.max_cut_m < 1.0 && s.cells_lowered_over_10m == 0, "{s:?}");
    assert!(s.cells_raised >= 9 && s.cells_raised <= 16 * fill_cells(32), "{s:?}");
    // the hole came up to the plateau, and nothing else moved by more than a metre
    for (i, (a, b)) in h.data.iter().zip(&before.data).enumerate() {
        let (x, y) = ((i % 120) as i64, (i / 120) as i64);
        if (x - 60).abs() <= 1 && (y - 60).abs() <= 1 {
            assert!(*a > 1499.0, "({x},{y}): {a}");
        } else {
            assert!((a - b).abs() < 1.0, "({x},{y}): {b} -> {a}");
        }
    }
    assert_eq!(drainage_shares(&h, MIN_DEPTH_M).sink_share, 0.0);
    // where the fill would cover a sketched valley's checked side, the breach stays
    let mut h = hole_in_a_plateau();
    let mut floor = keep.clone();
    floor[60 * 120 + 61] = 0.0;
    let s = breach_depressions(&mut h, &floors(&floor), 32, Hybrid::FillThenBreach);
    assert!(s.max_cut_m > 100.0 && s.cells_raised <= fill_cells(32), "{s:?}");
    // a trench it is, straight across the even plateau and down its side to the
    // border 59 cells away (nowhere nearer lies below the hole), and so reported
    assert!(s.straight_cuts == 1 && (50..=60).contains(&s.longest_straight_cut), "{s:?}");
}

#[test]
fn a_straight_stretch_is_measured_along_a_line_at_any_angle_and_only_where_cut_deep() {
    use super::carve::longest_straight_stretch;
    let all = |_: usize| true;
    // a row, a diagonal, and a stair-stepped line at 1 in 3: each straight whole
    let row: Vec<(i64, i64)> = (0..12).map(|x| (x, 5)).collect();
    let diagonal: Vec<(i64, i64)> = (0..20).map(|k| (k, k)).collect();
    let stairs: Vec<(i64, i64)> = (0..30).map(|x| (x, (x as f64 / 3.0).round() as i64)).collect();
    assert_eq!(longest_straight_stretch(&row, all), 12);
    assert_eq!(longest_straight_stretch(&diagonal, all), 20);
    assert_eq!(longest_straight_stretch(&stairs, all), 30);
    // an L: the longer arm and the corner
    let l: Vec<(i64, i64)> = (0..10).map(|x| (x, 0)).chain((1..6).map(|y| (9, y))).collect();
    assert_eq!(longest_straight_stretch(&l, all), 10);
    // a circle of radius 20: no 4.2 km of it straight (a chord of 10 cells strays
    // 0.63 of a cell from the arc)
    let circle: Vec<(i64, i64)> = (0..126)
        .map(|k| {
            let t = k as f64 / 20.0;
            ((20.0 * t.cos()).round() as i64, (20.0 * t.sin()).round() as i64)
        })
        .collect();
    let c = longest_straight_stretch(&circle, all);
    assert!((5..=13).contains(&c), "{c}");
    // cells not cut deep break a stretch; none deep, none
    assert_eq!(longest_straight_stretch(&row, |i| i != 4), 7);
    assert_eq!(longest_straight_stretch(&row, |_| false), 0);
}

#[test]
fn a_coarse_level_breaches_a_long_lake_and_fills_a_deep_hole() {
    // a coarse level's conditioning: the dam's lake runs far up the valley, so the
    // gully through the dam cuts less than filling the lake would raise: breached
    // from the lake's pit, nothing raised
    let mut h = dammed();
    let before = h.clone();
    let keep = vec![f32::NEG_INFINITY; h.data.len()];
    let s = breach_depressions(&mut h, &floors(&keep), 32, Hybrid::BreachOrFill);
    assert_eq!((s.breached, s.left, s.bottoms_filled, s.cells_raised), (1, 0, 0, 0), "{s:?}");
    assert!(h.data.iter().zip(&before.data).all(|(a, b)| a <= b));
    assert_eq!(drainage_shares(&h, MIN_DEPTH_M).sink_share, 0.0);
    // the hole in the plateau: a breach would be a 40-cell trench hundreds of metres
    // deep; the hole is filled to the plateau instead, nothing lowered
    let mut h = hole_in_a_plateau();
    let before = h.clone();
    let keep = vec![f32::NEG_INFINITY; h.data.len()];
    let s = breach_depressions(&mut h, &floors(&keep), 32, Hybrid::BreachOrFill);
    assert_eq!((s.breached, s.left, s.cells_lowered), (0, 0, 0), "{s:?}");
    assert_eq!((s.bottoms_filled, s.filled_to_rim, s.cells_raised), (1, 1, 9), "{s:?}");
    assert!(h.data.iter().zip(&before.data).all(|(a, b)| a >= b && a - b < 601.0));
    assert_eq!(drainage_shares(&h, MIN_DEPTH_M).sink_share, 0.0);
}

#[test]
fn a_basin_closed_by_a_kept_ring_stays_closed() {
    let mut h = dammed();
    // the dam is a sketched ridge crest
    let keep: Vec<f32> =
        (0..h.data.len()).map(|i| if ((i % 120) as i64 - 50).abs() < 2 { f32::INFINITY } else { f32::NEG_INFINITY }).collect();
    let before = h.clone();
    let s = breach_depressions(&mut h, &floors(&keep), 32, Hybrid::FillThenBreach);
    assert_eq!((s.breached, s.left), (0, 1), "{s:?}");
    assert_eq!(h.data, before.data);
}

#[test]
fn a_valley_s_checked_sides_are_held_above_its_floor_and_its_line_is_not() {
    use crate::stages::sketch::analyse;
    // a valley stroke along y = 60 and a ridge stroke along y = 20 on a V falling to
    // the valley
    let (w, hh) = (160usize, 120usize);
    let mut s = Grid::new(w, hh, 128u8);
    for x in 10..150 {
        for dy in 0..3 {
            s.set(x, 59 + dy, 0);
            s.set(x, 19 + dy, 255);
        }
    }
    let sk = analyse(&s, 64);
    let h: Heightfield = Grid::from_vec(
        w,
        hh,
        (0..w * hh).map(|i| 1000.0 + 3.0 * ((i / w) as f32 - 60.0).abs() + 0.05 * (i % w) as f32).collect(),
    );
    let SketchFloors { floor, ceiling } = sketch_floors(&sk, &h, 64);
    let at = |x: usize, y: usize| floor[y * w + x];
    for x in 50..110 {
        let valley = h.get(x, 60);
        // the line and the cells beside it may be cut as deep as drainage needs
        assert!((59..62).all(|y| at(x, y) == f32::NEG_INFINITY), "x {x}");
        // where its cross-section is checked (16 and 32 cells each way: the ridge
        // lies beyond its reach), no lower than halfway up from the valley's floor to
        // its lowest checked side (16 cells off, 48 m up); the floor may be filled up
        // to there, no higher
        let split = valley + 24.0;
        for y in [76, 92] {
            assert!((at(x, y) - split).abs() < 1.0 && at(x, y) > split, "({x}, {y}): {} vs {split}", at(x, y));
        }
        let k = ceiling[&(60 * w + x)];
        assert!((k - split).abs() < 1.0 && k < at(x, 76), "x {x}: ceiling {k} vs {split}");
        // the ridge's crest is never cut; cells checked by nothing are free
        assert_eq!(at(x, 20), f32::INFINITY);
        assert_eq!(at(x, 110), f32::NEG_INFINITY);
    }
}

#[test]
fn no_fill_may_lift_a_valley_s_floor_to_where_a_breach_may_cut_its_sides() {
    use crate::stages::sketch::{analyse, cross_section};
    use ridgeline_terrain::FeatureKind;
    // a wavy valley stroke on rough ground that falls to it: whatever the fill and
    // the breach each do within their limits, every centre-line cell stays below
    // every cell its checked sides read (the fill raised a centre to its lowest side
    // while a breach cut that side to the centre's old level: a traced sketch's
    // valleys, 0.970 fitting after the conditioning against 0.994 before)
    let (w, hh) = (160usize, 120usize);
    let mut s = Grid::new(w, hh, 128u8);
    for x in 10..150 {
        let yc = 60.0 + 8.0 * (x as f32 / 17.0).sin();
        for dy in 0..3 {
            s.set(x, yc as usize + dy, 0);
        }
    }
    let sk = analyse(&s, 64);
    let rough = |x: usize, y: usize| ((x as f32 * 12.9898 + y as f32 * 78.233).sin() * 43_758.547).fract() * 40.0;
    let h: Heightfield =
        Grid::from_vec(w, hh, (0..w * hh).map(|i| 1000.0 + 2.0 * ((i / w) as f32 - 60.0).abs() + rough(i % w, i / w)).collect());
    let SketchFloors { floor, ceiling } = sketch_floors(&sk, &h, 64);
    let valleys = sk.graph(FeatureKind::Valley);
    let bounds = sk.bounds();
    let mut checked = 0;
    for p in valleys.pixels() {
        let k = ceiling[&(p as usize)];
        let cs = cross_section(valleys, p, 32.0, &bounds);
        for side in 0..2 {
            for t in [0.5, 1.0] {
                let (sx, sy) = cs.at(side, t * cs.reach[side]);
                let (x0, y0) = (sx.floor() as usize, sy.floor() as usize);
                for j in [(x0, y0), (x0 + 1, y0), (x0, y0 + 1), (x0 + 1, y0 + 1)].map(|(x, y)| y * w + x) {
                    if floor[j].is_finite() {
                        assert!(floor[j] > k, "side cell {j}: floor {} under the ceiling {k} of {p}", floor[j]);
                        checked += 1;
                    }
                }
            }
        }
    }
    assert!(checked > 1000, "{checked} side cells checked");
}

#[test]
fn a_breach_keeps_to_the_floors_where_it_can_and_drains_where_it_cannot() {
    let before = dammed();
    let n = before.data.len();
    // a floor 10 m below the dam's top across the valley at the dam: the only way
    // out is through it, so the breach goes through anyway (draining first)
    let mut floor = vec![f32::NEG_INFINITY; n];
    for y in 0..60 {
        let i = y * 120 + 50;
        floor[i] = before.data[i] - 10.0;
    }
    let mut h = before.clone();
    let s = breach_depressions(&mut h, &floors(&floor), 32, Hybrid::FillThenBreach);
    assert_eq!(s.left, 0, "{s:?}");
    assert_eq!(drainage_shares(&h, MIN_DEPTH_M).sink_share, 0.0);
    // floors a metre below the dam's surface beside the valley's floor (4 to 7
    // cells off it, where the gully's walls would cut metres): held, the gully
    // narrower there (no narrower than OUTPUT_GULLY_RADIUS)
    let mut floor = vec![f32::NEG_INFINITY; n];
    for x in 46..55 {
        for y in (23..27).chain(34..38) {
            floor[y * 120 + x] = before.data[y * 120 + x] - 1.0;
        }
    }
    let (mut h, mut free) = (before.clone(), before.clone());
    let s = breach_depressions(&mut h, &floors(&floor), 32, Hybrid::FillThenBreach);
    breach_depressions(&mut free, &floors(&vec![f32::NEG_INFINITY; n]), 32, Hybrid::FillThenBreach);
    assert_eq!((s.breached, s.left), (1, 0), "{s:?}");
    assert!(free.data.iter().zip(&floor).any(|(v, f)| v < f), "the floors bind");
    assert!(h.data.iter().zip(&floor).all(|(v, f)| v >= f), "a cell cut below its floor");
    assert_eq!(drainage_shares(&h, MIN_DEPTH_M).sink_share, 0.0);
}

/// A plain at 500 m with a 20 m deep bowl three cells from the left border.
fn bowl_beside_the_seam() -> Heightfield {
    let (w, h) = (120usize, 60usize);
    Grid::from_vec(
        w,
        h,
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32 - 3.0, (i / w) as f32 - 30.0);
                500.0 - 20.0 * (1.0 - (x * x + y * y) / 4.0).max(0.0)
            })
            .collect(),
    )
}

#[test]
fn on_a_torus_the_gully_to_the_seam_is_cut_on_both_sides_of_it() {
    let before = bowl_beside_the_seam();
    let keep = vec![f32::NEG_INFINITY; before.data.len()];
    let seam_jump = |h: &Heightfield| (0..60).map(|y| (h.get(0, y) - h.get(119, y)).abs()).fold(0f32, f32::max);
    let (mut plain, mut torus) = (before.clone(), before.clone());
    let sp = breach_depressions(&mut plain, &floors(&keep), 16, Hybrid::FillThenBreach);
    let st = breach_depressions_on_torus(&mut torus, &floors(&keep), 16, Hybrid::FillThenBreach);
    for (h, s) in [(&plain, sp), (&torus, st)] {
        assert_eq!((s.depressions, s.breached, s.left), (1, 1, 0), "{s:?}");
        assert_eq!(drainage_shares(h, MIN_DEPTH_M).sink_share, 0.0, "the bowl drains over the border");
    }
    // the torus's cut goes on round the seam, so the tile stays periodic; the
    // rectangle's stops at the border
    let lowered = |h: &Heightfield, x: usize| (0..60).any(|y| h.get(x, y) < before.get(x, y));
    assert!(lowered(&torus, 119) && lowered(&torus, 116) && !lowered(&plain, 119));
    assert!(seam_jump(&plain) > 5.0, "{}", seam_jump(&plain));
    assert!(seam_jump(&torus) < 0.25 * seam_jump(&plain), "{} vs {}", seam_jump(&torus), seam_jump(&plain));
    // and only near the bowl, measured round the seam
    for (i, (a, b)) in torus.data.iter().zip(&before.data).enumerate() {
        let x = (i % 120) as i64;
        assert!(a <= b && (a == b || (x - 3).rem_euclid(120).min((3 - x).rem_euclid(120)) <= 4 + MAX_GULLY_RADIUS as i64));
    }
}

#[test]
fn a_pit_s_own_flood_finds_its_depth() {
    let h = dammed();
    let level = water_levels(&h);
    let topo = Topology::plain(&h);
    let (_, pit, depth) = pits(&h, topo).0[0];
    let full = local_depth(&h, topo, pit, &mut Default::default());
    assert!((full - depth).abs() < 1e-3, "the dam's lake: {depth} m");
    assert!((level[pit] - h.data[pit] - depth).abs() < 1e-3);
}

#[test]
fn a_breach_keeps_the_narrowest_gullys_walls_off_a_held_side_where_it_can() {
    // a valley side held a metre below the surface two cells off the dammed valley's
    // floor: a gully along the floor would take its walls (even at OUTPUT_GULLY_RADIUS)
    // 17 m down there; the breach goes round, through the dam beyond the walls' reach
    let before = dammed();
    let n = before.data.len();
    let mut floor = vec![f32::NEG_INFINITY; n];
    for x in 40..60 {
        let i = 28 * 120 + x;
        floor[i] = before.data[i] - 1.0;
    }
    let mut h = before.clone();
    let s = breach_depressions(&mut h, &floors(&floor), 32, Hybrid::FillThenBreach);
    assert_eq!((s.breached, s.left), (1, 0), "{s:?}");
    assert_eq!(drainage_shares(&h, MIN_DEPTH_M).sink_share, 0.0);
    let worst = h.data.iter().zip(&floor).map(|(v, f)| f - v).fold(f32::NEG_INFINITY, f32::max);
    assert!(worst <= 0.0, "a held cell {worst} m below its floor");
}

#[test]
fn a_search_that_lifts_only_restrictions_a_missed_one_never_met_finds_nothing_either() {
    use super::search::{breach_path, Limits, Miss, Restrictions, Scratch};
    // rough terrains of pits and sills, with held floors (a valley's sides) and crests,
    // searched from every pit under every set of restrictions the stage tries and
    // under every cost bound from tight to none
    let (w, hh) = (48usize, 40usize);
    let mut checked = 0;
    for seed in 0..6u32 {
        let noise = |x: usize, y: usize| {
            let k = (x as u32).wrapping_mul(73_856_093) ^ (y as u32).wrapping_mul(19_349_663) ^ seed.wrapping_mul(83_492_791);
            (k.wrapping_mul(2_654_435_761) >> 16) as f32 / 65_536.0
        };
        let h: Heightfield = Grid::from_vec(
            w,
            hh,
            (0..w * hh)
                .map(|i| {
                    let (x, y) = (i % w, i / w);
                    300.0 + 2.0 * x as f32 + 40.0 * (x as f32 * 0.45).sin() * (y as f32 * 0.35).cos() + 30.0 * noise(x, y)
                })
                .collect(),
        );
        let topo = Topology::plain(&h);
        let floor: Vec<f32> = (0..w * hh)
            .map(|i| match (i % w, i / w) {
                (x, _) if x == 20 + seed as usize => f32::INFINITY,
                (_, y) if y == 12 || y == 28 => h.data[i] - 5.0,
                _ => f32::NEG_INFINITY,
            })
            .collect();
        let near = floors::near_held(&floor, topo);
        let pits: Vec<usize> = (0..w * hh).filter(|&c| !search::has_way_down(&h, topo, c)).collect();
        let configs: Vec<Restrictions> =
            [(true, true, 8), (true, false, 8), (true, false, 40), (false, false, 8), (false, false, 40)]
                .map(|(held, spare, reach)| Restrictions { held, spare, reach })
                .to_vec();
        let mut scratch = Scratch::default();
        let ground = super::low_ground::LowGround::of(&h, super::carve::wall_slope(&h) / WALL_PER_MEDIAN_SLOPE);
        for &pit in &pits {
            for max_cost in [5.0, 40.0, 400.0, f32::INFINITY] {
                let run = |r: Restrictions, scratch: &mut Scratch| {
                    let floor = Floors { floor: &floor, held: r.held, spare: r.spare, near: &near };
                    breach_path(&h, topo, pit, floor, &ground, Limits { reach: r.reach, max_cut: 80.0, max_cost }, scratch)
                };
                let results: Vec<Result<Vec<usize>, Miss>> = configs.iter().map(|&r| run(r, &mut scratch)).collect();
                for (i, old) in configs.iter().enumerate() {
                    let Err(miss) = results[i] else { continue };
                    for (j, new) in configs.iter().enumerate() {
                        if i != j && miss.covers(*old, *new) {
                            assert_eq!(
                                results[j],
                                Err(miss),
                                "pit {pit}, cost ≤ {max_cost}: {old:?} missed as {miss:?}, {new:?}"
                            );
                            checked += 1;
                        }
                    }
                }
            }
        }
    }
    // the property was put to the test: searches with restrictions lifted
    assert!(checked > 200, "{checked} pairs checked");
}

#[test]
fn a_flood_s_depth_does_not_depend_on_the_floods_before_it() {
    // one scratch handed from flood to flood (its cell set cleared in between)
    // against a fresh one per flood, from every cell without a way down of a rough
    // terrain, stopped early or not
    let (w, hh) = (90usize, 70usize);
    let h: Heightfield = Grid::from_vec(
        w,
        hh,
        (0..w * hh)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                500.0 + 1.5 * x + 60.0 * (x * 0.31).sin() * (y * 0.23).cos() + 25.0 * ((x * 1.7 + y * 2.3).sin())
            })
            .collect(),
    );
    let topo = Topology::plain(&h);
    let pits: Vec<usize> = (0..w * hh).filter(|&c| !search::has_way_down(&h, topo, c)).collect();
    assert!(pits.len() > 20, "{} pits", pits.len());
    let mut shared = Default::default();
    let mut deep = 0;
    for &pit in &pits {
        let again = local_depth(&h, topo, pit, &mut shared);
        let fresh = local_depth(&h, topo, pit, &mut Default::default());
        assert_eq!(again.to_bits(), fresh.to_bits(), "pit {pit}");
        deep += usize::from(fresh > MIN_DEPTH_M);
    }
    assert!(deep > 5, "{deep} pits deeper than {MIN_DEPTH_M} m");
}

#[test]
fn each_cell_changed_is_counted_once_however_many_gullies_cross_it() {
    // a slope of 0.5 m a cell roughened by ±20 m of hashed noise: hundreds of pits a
    // few cells apart, whose gullies cross each other
    let (w, hh) = (80usize, 80usize);
    let noise = |i: usize| {
        let k = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 40;
        (k % 4001) as f32 / 100.0 - 20.0
    };
    let mut h = Grid::from_vec(w, hh, (0..w * hh).map(|i| 0.5 * (i % w) as f32 + noise(i)).collect());
    let before = h.clone();
    let keep = vec![f32::NEG_INFINITY; h.data.len()];
    let s = breach_depressions(&mut h, &floors(&keep), 32, Hybrid::FillThenBreach);
    let lowered = h.data.iter().zip(&before.data).filter(|(a, b)| a < b).count();
    let raised = h.data.iter().zip(&before.data).filter(|(a, b)| a > b).count();
    assert!(s.breached > 20 && lowered > 0, "{s:?}");
    // a cell raised by a filled bottom and then cut (or cut, then raised) ends on one
    // side of where it was but was changed both ways: only those may differ
    assert!(s.cells_lowered >= lowered && s.cells_lowered <= lowered + s.cells_raised, "{lowered} lowered: {s:?}");
    assert!(s.cells_raised >= raised && s.cells_raised <= raised + s.cells_lowered, "{raised} raised: {s:?}");
    assert!(s.cells_lowered_over_10m <= s.cells_lowered, "{s:?}");
}

#[test]
fn a_cut_shallower_than_the_wall_s_slope_is_a_gully_three_cells_wide() {
    // a steep valley (40 m a cell up each side, so walls may be about 80 m a cell)
    // falling 0.8 m a cell to the left border, dammed 30 m high at x = 50: the lake
    // behind is one cell wide and 37 long, and the cut through the dam is shallower
    // than the walls may be steep
    let (w, hh) = (120usize, 60usize);
    let mut h = Grid::from_vec(
        w,
        hh,
        (0..w * hh)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                let dam = if (x - 50.0).abs() < 2.0 { 30.0 } else { 0.0 };
                200.0 + 0.8 * x + 40.0 * (y - 30.0).abs() + dam
            })
            .collect(),
    );
    let before = h.clone();
    let keep = vec![f32::NEG_INFINITY; h.data.len()];
    let s = breach_depressions(&mut h, &floors(&keep), 32, Hybrid::FillThenBreach);
    assert_eq!((s.breached, s.left), (1, 0), "{s:?}");
    assert_eq!(drainage_shares(&h, MIN_DEPTH_M).sink_share, 0.0, "nothing closed is left");
    // the gully runs along the valley's floor (y = 30), one cell each side of it
    let rows: Vec<usize> = (0..w * hh).filter(|&i| h.data[i] < before.data[i]).map(|i| i / w).collect();
    assert!(!rows.is_empty() && rows.iter().all(|&y| y.abs_diff(30) <= 1), "rows lowered: {rows:?}");
}

#[test]
fn a_pit_deep_in_a_dome_with_no_lower_ground_within_the_far_reach_is_breached_to_the_border() {
    // a dome rising 2 m a cell from the border (500 m) to 740 m at its centre, with a
    // bowl there sunk to 300 m: no cell within FAR_SEARCH_PATCHES patches (64 cells at
    // a patch of 2) is lower, only the border 120 cells away lets water out
    let n = 240usize;
    let h = Grid::from_vec(
        n,
        n,
        (0..n * n)
            .map(|i| {
                let (x, y) = (i % n, i / n);
                let edge = x.min(y).min(n - 1 - x).min(n - 1 - y) as f32;
                let r = ((x as f32 - 120.0).powi(2) + (y as f32 - 120.0).powi(2)).sqrt();
                let dome = 500.0 + 2.0 * edge;
                if r < 6.0 {
                    dome.min(300.0 + 70.0 * r)
                } else {
                    dome
                }
            })
            .collect(),
    );
    let patch = 2;
    assert!(FAR_SEARCH_PATCHES * patch < 120);
    let mut t = h.clone();
    let keep = vec![f32::NEG_INFINITY; n * n];
    let s = breach_depressions(&mut t, &floors(&keep), patch, Hybrid::FillThenBreach);
    assert_eq!(s.left, 0, "{s:?}");
    assert!(drainage_shares(&h, SINK_DEPTH_M).sink_share > 0.0, "the bowl is closed");
    let after = drainage_shares(&t, SINK_DEPTH_M);
    assert!(after.border_share > 0.999 && after.sink_share == 0.0, "{after:?}: {s:?}");
}
