//! Generated exemplars: sources whose heights a recipe makes, so that a library can
//! mix real DEMs with synthetic terrain (the ETRI patent's noise-based models beside
//! real ones) and a worker receives the recipe, not the samples. A [`Recipe`] names
//! a generator and its parameters; [`from_recipe`] is the one place that turns a
//! recipe back into a source, on the coordinator and on a worker alike.
//!
//! Generators are written here rather than taken from a noise crate: their output must
//! be bit-identical on every machine and build (a worker regenerates what the
//! coordinator planned), so they use only f64 arithmetic with no transcendental
//! functions and an integer hash, whose results IEEE 754 fixes exactly.
//!
//! [`Noise`] is the generator, in three kinds ([`NoiseKind`]), each built from octaves
//! of smoothly interpolated lattice (value) noise, octave k at `lacunarity`^k times
//! the frequency and `gain`^k times the amplitude of the first:
//! - `fbm`: fractional Brownian motion, rolling hills to rough uplands;
//! - `ridged`: Musgrave's ridged multifractal (Ebert et al., *Texturing and Modeling*,
//!   ch. 16): each octave is `(offset - |n|)²`, weighted by the octave before it, so
//!   sharp crests branch into spurs and the ground between them stays smooth;
//! - `warped`: fBm sampled at a point displaced by two other fBm fields (domain
//!   warping), `warp_cells` the largest displacement: sinuous, folded landforms.
//!
//! Every kind is scaled to span `base_m ..= base_m + relief_m` exactly.
//!
//! Each octave is the mean of value noise on two lattices turned apart, both turned
//! by a further rotation per octave with the exact rational matrix of the 3-4-5
//! triangle (about 53°) and shifted by an offset of their own ([`octave_noise`],
//! [`octave_point`]): with every octave on one axis-aligned lattice, lacunarity 2 put
//! each octave's lattice lines on the last one's and the terrain showed square
//! plateaus and straight, axis-aligned edges in its hillshade. The fullest of nine
//! 10-degree bins of gradient direction over the emptiest (256², a 64-cell
//! wavelength, 7 octaves): fBm 1.10 and ridged 1.65 on one lattice, 1.07 and 1.18 now.

use crate::error::{Result, TerrainError};
pub use crate::exemplar_source::Recipe;
use crate::exemplar_source::{digest, scaled_area, ExemplarSource, Transport};
use crate::grid::{Grid, Heightfield};
use crate::library::resample_to_cell;
use rayon::prelude::*;
use std::path::Path;
use std::sync::Arc;

/// Largest side a generator makes, in cells.
pub const MAX_GENERATED_SIDE: usize = 16384;

/// The source a recipe describes, its parameters checked.
pub fn from_recipe(r: &Recipe) -> Result<Arc<dyn ExemplarSource>> {
    let bad = |m: String| TerrainError::Invalid { path: format!("generator '{}'", r.generator).into(), message: m };
    let kind = NoiseKind::ALL.into_iter().find(|k| k.name() == r.generator).ok_or_else(|| {
        let known: Vec<&str> = NoiseKind::ALL.iter().map(|k| k.name()).collect();
        bad(format!("'{}' is not a generator (known: {})", r.generator, known.join(", ")))
    })?;
    let mut noise: Noise = serde_json::from_value(r.params.clone()).map_err(|e| bad(format!("parameters: {e}")))?;
    noise.kind = kind;
    noise.check().map_err(bad)?;
    Ok(Arc::new(noise))
}

/// Every source of a library (a folder of DEMs, a DEM file or a manifest): its files
/// ([`crate::exemplar_source::file_sources`]), then a manifest's `[[generator]]`
/// entries made by [`from_recipe`], in the manifest's order; a bad one is named with
/// the manifest and its place in it.
pub fn library_sources(library: &Path) -> Result<Vec<Arc<dyn ExemplarSource>>> {
    let mut sources = crate::exemplar_source::file_sources(library)?;
    if library.is_file() && !crate::dem_formats::is_dem_path(library) {
        for (i, g) in crate::library::read_manifest_generators(library)?.into_iter().enumerate() {
            let recipe = Recipe { generator: g.generator, params: g.params };
            sources.push(from_recipe(&recipe).map_err(|e| TerrainError::Invalid {
                path: library.to_path_buf(),
                message: format!("generator {}: {e}", i + 1),
            })?);
        }
    }
    Ok(sources)
}

/// The kind of a [`Noise`] generator (see the module header); its name is the
/// recipe's `generator`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NoiseKind {
    #[default]
    Fbm,
    Ridged,
    Warped,
}

impl NoiseKind {
    pub const ALL: [NoiseKind; 3] = [NoiseKind::Fbm, NoiseKind::Ridged, NoiseKind::Warped];

    pub fn name(self) -> &'static str {
        match self {
            NoiseKind::Fbm => "fbm",
            NoiseKind::Ridged => "ridged",
            NoiseKind::Warped => "warped",
        }
    }
}

/// A noise generator (see the module header). The parameters are the recipe's
/// `params`; the kind is its `generator`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Noise {
    #[serde(skip)]
    pub kind: NoiseKind,
    /// The name the exemplar goes by.
    pub name: String,
    pub width: usize,
    pub height: usize,
    pub cell_size_m: f32,
    pub seed: u64,
    /// Wavelength of the first octave, in cells.
    pub wavelength_cells: f64,
    pub octaves: u32,
    /// Amplitude factor from one octave to the next (0.5: the classic 1/f).
    pub gain: f64,
    /// Frequency factor from one octave to the next.
    pub lacunarity: f64,
    /// Peak-to-peak relief in metres and the lowest height.
    pub relief_m: f64,
    pub base_m: f64,
    /// `warped` only: the largest displacement of a sample point, in cells (default
    /// half the first octave's wavelength).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub warp_cells: Option<f64>,
    /// `ridged` only: the offset a crest rises from (default 1; above 1 the ground
    /// between crests is rougher).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ridge_offset: Option<f64>,
}

impl Noise {
    /// A generator of `kind` with the usual shape: the first octave an eighth of the
    /// longer side, 8 octaves, gain 0.5, lacunarity 2, 1,500 m of relief from 0 m.
    pub fn new(kind: NoiseKind, name: impl Into<String>, width: usize, height: usize, cell_size_m: f32, seed: u64) -> Self {
        Noise {
            kind,
            name: name.into(),
            width,
            height,
            cell_size_m,
            seed,
            wavelength_cells: (width.max(height) as f64 / 8.0).max(2.0),
            octaves: 8,
            gain: 0.5,
            lacunarity: 2.0,
            relief_m: 1500.0,
            base_m: 0.0,
            warp_cells: None,
            ridge_offset: None,
        }
    }

    /// Refuses parameters that make no terrain or too large a one, and a parameter
    /// of another kind.
    pub fn check(&self) -> std::result::Result<(), String> {
        if self.width < 2 || self.height < 2 || self.width > MAX_GENERATED_SIDE || self.height > MAX_GENERATED_SIDE {
            return Err(format!("{} x {} cells: each side must be within 2..={MAX_GENERATED_SIDE}", self.width, self.height));
        }
        let finite_positive = |v: f64| v.is_finite() && v > 0.0;
        if !(finite_positive(self.cell_size_m as f64)
            && finite_positive(self.wavelength_cells)
            && finite_positive(self.relief_m)
            && self.base_m.is_finite())
        {
            return Err("cell size, wavelength and relief must be positive numbers, the base a number".into());
        }
        let shaped =
            (1..=16).contains(&self.octaves) && self.gain > 0.0 && self.gain < 1.0 && (1.0..=4.0).contains(&self.lacunarity);
        if !shaped {
            return Err("octaves within 1..=16, gain within (0, 1), lacunarity within 1..=4".into());
        }
        let only = |what: &str, kind: NoiseKind| format!("{what} is a parameter of '{}' only", kind.name());
        match (self.warp_cells, self.kind) {
            (Some(_), k) if k != NoiseKind::Warped => return Err(only("warp_cells", NoiseKind::Warped)),
            (Some(w), _) if !(w.is_finite() && (0.0..=MAX_GENERATED_SIDE as f64).contains(&w)) => {
                return Err(format!("warp_cells {w}: give a displacement from 0 to {MAX_GENERATED_SIDE} cells"))
            }
            _ => {}
        }
        match (self.ridge_offset, self.kind) {
            (Some(_), k) if k != NoiseKind::Ridged => return Err(only("ridge_offset", NoiseKind::Ridged)),
            (Some(o), _) if !(o.is_finite() && (0.5..=2.0).contains(&o)) => {
                return Err(format!("ridge_offset {o}: give an offset from 0.5 to 2"))
            }
            _ => {}
        }
        Ok(())
    }

    /// The recipe of this generator.
    pub fn recipe(&self) -> Recipe {
        Recipe { generator: self.kind.name().into(), params: serde_json::to_value(self).unwrap_or_default() }
    }

    /// The heights at the generator's own cell size.
    pub fn generate(&self) -> Heightfield {
        let w = self.width;
        let mut raw = vec![0f64; w * self.height];
        raw.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, v) in row.iter_mut().enumerate() {
                *v = self.sample(x as f64, y as f64);
            }
        });
        let (lo, hi) = raw.iter().fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
        let span = (hi - lo).max(1e-12);
        let data = raw.iter().map(|&v| (self.base_m + (v - lo) / span * self.relief_m) as f32).collect();
        Grid::from_vec(w, self.height, data)
    }

    /// The unscaled value at cell (x, y).
    fn sample(&self, x: f64, y: f64) -> f64 {
        match self.kind {
            NoiseKind::Fbm => self.fbm(x, y, self.octaves, self.seed),
            NoiseKind::Ridged => self.ridged(x, y),
            NoiseKind::Warped => {
                // two displacement fields of the broad octaves, salted apart from the
                // terrain's own, each within [-1, 1]
                let broad = self.octaves.min(4);
                let norm: f64 = (0..broad).scan(1.0, |amp, _| Some(std::mem::replace(amp, *amp * self.gain))).sum();
                let qx = self.fbm(x, y, broad, self.seed ^ 0xA5A5_0001) / norm;
                let qy =
                    self.fbm(x + 0.37 * self.wavelength_cells, y + 0.61 * self.wavelength_cells, broad, self.seed ^ 0xA5A5_0002)
                        / norm;
                let warp = self.warp_cells.unwrap_or(self.wavelength_cells / 2.0);
                self.fbm(x + warp * qx, y + warp * qy, self.octaves, self.seed)
            }
        }
    }

    /// fBm of `octaves` octaves at cell (x, y) (within ± the sum of the amplitudes,
    /// below 1 / (1 - gain)).
    fn fbm(&self, x: f64, y: f64, octaves: u32, seed: u64) -> f64 {
        let (mut freq, mut amp, mut sum) = (1.0 / self.wavelength_cells, 1.0, 0.0);
        for octave in 0..octaves {
            sum += amp * octave_noise(x * freq, y * freq, octave, octave_salt(seed, octave));
            freq *= self.lacunarity;
            amp *= self.gain;
        }
        sum
    }

    /// Ridged multifractal at cell (x, y): each octave's ridge `(offset - |n|)²`,
    /// weighted by twice the ridge of the octave before (clamped to 1), so detail
    /// gathers on the crests.
    fn ridged(&self, x: f64, y: f64) -> f64 {
        let offset = self.ridge_offset.unwrap_or(1.0);
        let (mut freq, mut amp, mut sum, mut weight) = (1.0 / self.wavelength_cells, 1.0, 0.0, 1.0);
        for octave in 0..self.octaves {
            let n = octave_noise(x * freq, y * freq, octave, octave_salt(self.seed, octave));
            let ridge = (offset - n.abs()).max(0.0);
            let signal = ridge * ridge * weight;
            sum += amp * signal;
            weight = (signal * 2.0).clamp(0.0, 1.0);
            freq *= self.lacunarity;
            amp *= self.gain;
        }
        sum
    }
}

/// Where octave `octave` samples its lattice for the point (x, y) (in its own
/// frequency's units): turned `octave + 1` times by the rotation (3/5, -4/5; 4/5, 3/5),
/// exact in rationals, then shifted off the lattice by an offset of its own.
fn octave_point(x: f64, y: f64, octave: u32) -> (f64, f64) {
    let (mut u, mut v) = (x, y);
    for _ in 0..=octave {
        (u, v) = (0.6 * u - 0.8 * v, 0.8 * u + 0.6 * v);
    }
    let k = octave as f64;
    (u + 0.3125 * k, v + 0.5625 * k)
}

/// One octave's noise at (x, y) (in its frequency's units): the mean of value noise
/// on two lattices turned apart (by the 3-4-5 rotation), scaled back to the spread of
/// one, so neither lattice's grain shows.
fn octave_noise(x: f64, y: f64, octave: u32, salt: u64) -> f64 {
    let (u, v) = octave_point(x, y, octave);
    let (s, t) = octave_point(u, v, 0);
    const SQRT_HALF: f64 = std::f64::consts::FRAC_1_SQRT_2;
    (value_noise(u, v, salt) + value_noise(s + 0.5, t + 0.25, salt ^ 0x5151_7e1f)) * SQRT_HALF
}

fn octave_salt(seed: u64, octave: u32) -> u64 {
    seed ^ (octave as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
}

/// Value noise at (x, y): hashed lattice values in [-1, 1] blended by the quintic
/// smoothstep (continuous slope and curvature across lattice lines).
fn value_noise(x: f64, y: f64, salt: u64) -> f64 {
    let (xf, yf) = (x.floor(), y.floor());
    let (ix, iy) = (xf as i64, yf as i64);
    let (tx, ty) = (fade(x - xf), fade(y - yf));
    let at = |dx: i64, dy: i64| lattice(ix + dx, iy + dy, salt);
    let top = at(0, 0) + (at(1, 0) - at(0, 0)) * tx;
    let bottom = at(0, 1) + (at(1, 1) - at(0, 1)) * tx;
    top + (bottom - top) * ty
}

fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// A lattice point's value in [-1, 1] (splitmix64 of the point and the salt).
fn lattice(x: i64, y: i64, salt: u64) -> f64 {
    let mut z = (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F) ^ salt;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

impl ExemplarSource for Noise {
    fn name(&self) -> String {
        self.name.clone()
    }
    fn cell_size_m(&self) -> Option<f32> {
        Some(self.cell_size_m)
    }
    fn cells_at(&self, out_cell: Option<f32>) -> u64 {
        scaled_area(self.width, self.height, Some(self.cell_size_m), out_cell)
    }
    fn heights(&self, out_cell: Option<f32>, max_side: u32) -> Result<Heightfield> {
        let what = Path::new(&self.name);
        crate::dem_formats::check_size(what, self.width as u64, self.height as u64, max_side)?;
        resample_to_cell(self.generate(), Some(self.cell_size_m), out_cell, max_side, what)
    }
    fn identity(&self, out_cell: Option<f32>) -> Result<String> {
        let recipe = serde_json::to_vec(&self.recipe()).map_err(|e| TerrainError::Other(e.to_string()))?;
        Ok(digest(&[&recipe, format!("generated:{out_cell:?}").as_bytes()]))
    }
    fn transport(&self) -> Result<Transport> {
        Ok(Transport::Recipe(self.recipe()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fbm() -> Noise {
        Noise {
            wavelength_cells: 32.0,
            octaves: 5,
            relief_m: 1200.0,
            base_m: 300.0,
            ..Noise::new(NoiseKind::Fbm, "hills", 96, 80, 90.0, 7)
        }
    }

    #[test]
    fn a_recipe_makes_the_same_heights_again_and_fbm_spans_its_relief() {
        let f = fbm();
        let a = f.generate();
        let again = from_recipe(&f.recipe()).unwrap().heights(Some(90.0), 4096).unwrap();
        assert_eq!(
            a.data.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            again.data.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
        let (lo, hi) = a.data.iter().fold((f32::MAX, f32::MIN), |(l, h), &v| (l.min(v), h.max(v)));
        assert!((lo - 300.0).abs() < 1e-3 && (hi - 1500.0).abs() < 1e-2, "{lo}..{hi}");
        // continuous: neighbouring cells of a row differ far less than the relief
        let step = a.data.chunks(a.width).flat_map(|row| row.windows(2).map(|w| (w[1] - w[0]).abs())).fold(0f32, f32::max);
        assert!(step < 1200.0 / 8.0, "largest step {step}");
        let other = Noise { seed: 8, ..fbm() }.generate();
        assert!(other.data.iter().zip(&a.data).filter(|(x, y)| (*x - *y).abs() > 50.0).count() > a.data.len() / 4);
        assert_ne!(f.identity(Some(90.0)).unwrap(), Noise { seed: 8, ..fbm() }.identity(Some(90.0)).unwrap());
        // resampled like a DEM to another cell size
        assert_eq!(f.heights(Some(45.0), 4096).unwrap().width, 192);
    }

    /// The 2nd and 98th percentiles of the 5-point Laplacian (curvature of crests
    /// and of hollows).
    fn curvature_tails(h: &Heightfield) -> (f32, f32) {
        let mut lap = Vec::new();
        for y in 1..h.height - 1 {
            for x in 1..h.width - 1 {
                let c = h.get(x, y);
                lap.push(h.get(x - 1, y) + h.get(x + 1, y) + h.get(x, y - 1) + h.get(x, y + 1) - 4.0 * c);
            }
        }
        lap.sort_by(f32::total_cmp);
        (lap[lap.len() / 50], lap[lap.len() * 49 / 50])
    }

    #[test]
    fn ridged_noise_has_sharp_crests_and_smooth_hollows_and_fbm_is_even_handed() {
        let shape = |kind| Noise { wavelength_cells: 48.0, octaves: 6, ..Noise::new(kind, "n", 192, 192, 90.0, 11) };
        let (crest, hollow) = curvature_tails(&shape(NoiseKind::Ridged).generate());
        // crests (negative Laplacian) are far sharper than the hollows between them
        // (2.0 to 2.1 over seeds 1..=5 and 11; fBm 0.98 to 1.02)
        assert!(-crest > 1.6 * hollow, "ridged: crest {crest}, hollow {hollow}");
        let (crest, hollow) = curvature_tails(&shape(NoiseKind::Fbm).generate());
        assert!(-crest < 1.25 * hollow && hollow < -1.25 * crest, "fbm: crest {crest}, hollow {hollow}");
        // the same recipe again through the manifest's path, bit for bit
        let r = shape(NoiseKind::Ridged);
        let again = from_recipe(&r.recipe()).unwrap().heights(None, 4096).unwrap();
        assert!(again.data.iter().zip(&r.generate().data).all(|(a, b)| a.to_bits() == b.to_bits()));
        assert_eq!(r.recipe().generator, "ridged");
        // the offset changes the terrain
        let rougher = Noise { ridge_offset: Some(1.4), ..shape(NoiseKind::Ridged) }.generate();
        assert!(rougher.data.iter().zip(&r.generate().data).filter(|(a, b)| (*a - *b).abs() > 20.0).count() > 192 * 192 / 4);
    }

    #[test]
    fn warped_noise_is_fbm_displaced_and_stays_continuous() {
        let shape = |warp| Noise {
            wavelength_cells: 40.0,
            octaves: 6,
            warp_cells: warp,
            ..Noise::new(NoiseKind::Warped, "w", 160, 128, 90.0, 5)
        };
        let fbm = Noise { kind: NoiseKind::Fbm, ..shape(None) }.generate();
        // no displacement: exactly the fBm of the same parameters
        let still = shape(Some(0.0)).generate();
        assert!(still.data.iter().zip(&fbm.data).all(|(a, b)| a.to_bits() == b.to_bits()));
        let warped = shape(Some(30.0)).generate();
        let moved = warped.data.iter().zip(&fbm.data).filter(|(a, b)| (*a - *b).abs() > 100.0).count();
        assert!(moved > warped.data.len() / 4, "{moved} cells moved by 100 m");
        // continuous: the displacement is smooth, so no step between neighbours is
        // more than a few times the fBm's largest (218 m against 115 m here)
        let step =
            warped.data.chunks(warped.width).flat_map(|row| row.windows(2).map(|w| (w[1] - w[0]).abs())).fold(0f32, f32::max);
        let fstep = fbm.data.chunks(fbm.width).flat_map(|row| row.windows(2).map(|w| (w[1] - w[0]).abs())).fold(0f32, f32::max);
        assert!(step < 2.5 * fstep, "largest step {step}, fBm's {fstep}");
        let (lo, hi) = warped.finite_range().unwrap();
        assert!(lo.abs() < 1e-3 && (hi - 1500.0).abs() < 1e-2, "{lo}..{hi}");
        let r = shape(Some(30.0)).recipe();
        assert_eq!(r.generator, "warped");
        assert_eq!(r.params["warp_cells"], serde_json::json!(30.0));
    }

    /// How unevenly the gradients point: over nine 10-degree bins of their direction
    /// folded to 0..90 degrees (a lattice's grain repeats every 90), the fullest bin
    /// over the emptiest (1 for isotropic terrain).
    fn grain(h: &Heightfield) -> f64 {
        let mut bins = [0usize; 9];
        for y in 1..h.height - 1 {
            for x in 1..h.width - 1 {
                let (gx, gy) = ((h.get(x + 1, y) - h.get(x - 1, y)) as f64, (h.get(x, y + 1) - h.get(x, y - 1)) as f64);
                if gx.hypot(gy) < 1e-6 {
                    continue;
                }
                let a = gy.atan2(gx).to_degrees().rem_euclid(90.0);
                bins[((a / 10.0) as usize).min(8)] += 1;
            }
        }
        *bins.iter().max().unwrap() as f64 / (*bins.iter().min().unwrap()).max(1) as f64
    }

    #[test]
    fn octaves_on_turned_lattices_leave_no_axis_aligned_grain() {
        for kind in [NoiseKind::Fbm, NoiseKind::Ridged, NoiseKind::Warped] {
            let mut n = Noise::new(kind, "n", 256, 256, 90.0, 7);
            n.wavelength_cells = 64.0;
            n.octaves = 7;
            let g = grain(&n.generate());
            eprintln!("{kind:?}: grain {g:.3}");
            assert!(g < 1.3, "{kind:?}: {g:.3} times as many gradients in one direction as in another");
        }
    }

    #[test]
    fn bad_recipes_are_refused_with_the_reason() {
        let e = |r: Recipe| from_recipe(&r).unwrap_err().to_string();
        let plasma = e(Recipe { generator: "plasma".into(), params: serde_json::json!({}) });
        assert!(plasma.contains("'plasma' is not a generator (known: fbm, ridged, warped)"), "{plasma}");
        let mut r = fbm().recipe();
        r.params["octaves"] = serde_json::json!(40);
        assert!(e(r).contains("octaves"));
        let mut r = fbm().recipe();
        r.params["width"] = serde_json::json!(1_000_000);
        assert!(e(r).contains("16384"));
        let mut r = fbm().recipe();
        r.params["colour"] = serde_json::json!("red");
        assert!(e(r).contains("colour"));
        // a parameter of another kind, or out of its range
        let mut r = fbm().recipe();
        r.params["warp_cells"] = serde_json::json!(10);
        assert!(e(r).contains("warp_cells is a parameter of 'warped' only"));
        let mut r = fbm().recipe();
        r.generator = "ridged".into();
        r.params["ridge_offset"] = serde_json::json!(7);
        assert!(e(r).contains("ridge_offset 7"));
        let mut r = fbm().recipe();
        r.generator = "warped".into();
        r.params["warp_cells"] = serde_json::json!(-3);
        assert!(e(r).contains("warp_cells -3"));
    }

    #[test]
    fn a_manifest_mixes_files_and_generators_and_names_a_bad_generator() {
        let d = std::env::temp_dir().join(format!("rl-manifest-gen-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        std::fs::write(d.join("a.hgt"), [0u8; 8]).unwrap();
        let fbm = "[[generator]]\ngenerator = \"fbm\"\n[generator.params]\nname = \"hills\"\nwidth = 96\nheight = 80\ncell_size_m = 90\nseed = 4\nwavelength_cells = 32\noctaves = 5\ngain = 0.5\nlacunarity = 2\nrelief_m = 900\nbase_m = 100\n";
        let m = d.join("lib.toml");
        std::fs::write(&m, format!("[[exemplar]]\nfile = \"a.hgt\"\n{fbm}")).unwrap();
        let sources = library_sources(&m).unwrap();
        let names: Vec<String> = sources.iter().map(|s| s.name()).collect();
        assert_eq!(names, ["a.hgt", "hills"]);
        let h = sources[1].heights(Some(90.0), 1024).unwrap();
        let (lo, hi) = h.finite_range().unwrap();
        assert_eq!((h.width, h.height), (96, 80));
        assert!((lo - 100.0).abs() < 1e-3 && (hi - 1000.0).abs() < 1e-3, "{lo}..{hi}");
        // a library of generators alone
        std::fs::write(&m, fbm).unwrap();
        assert_eq!(library_sources(&m).unwrap().len(), 1);
        assert!(crate::library::scan_library(&m).unwrap().is_empty());
        // an unknown generator or a bad parameter is named with the manifest
        std::fs::write(&m, fbm.replace("\"fbm\"", "\"perlin\"")).unwrap();
        let e = library_sources(&m).unwrap_err().to_string();
        assert!(e.contains("lib.toml") && e.contains("generator 1") && e.contains("'perlin' is not a generator"), "{e}");
        std::fs::write(&m, fbm.replace("octaves = 5", "octaves = 99")).unwrap();
        let e = library_sources(&m).unwrap_err().to_string();
        assert!(e.contains("generator 1") && e.contains("octaves"), "{e}");
        // a manifest that lists nothing says so
        std::fs::write(&m, "").unwrap();
        assert!(crate::library::scan_library(&m).unwrap_err().to_string().contains("lists no exemplar"));
        let _ = std::fs::remove_dir_all(&d);
    }
}
