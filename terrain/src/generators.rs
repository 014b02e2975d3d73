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
//! The first generator is [`Fbm`]: fractional Brownian motion of value noise (octaves
//! of smoothly interpolated lattice noise, each at `lacunarity` times the frequency
//! and `gain` times the amplitude of the one before).

use crate::error::{Result, TerrainError};
pub use crate::exemplar_source::Recipe;
use crate::exemplar_source::{digest, scaled_area, ExemplarSource, Transport};
use crate::grid::{Grid, Heightfield};
use crate::library::resample_to_cell;
use std::path::Path;
use std::sync::Arc;

/// Largest side a generator makes, in cells.
pub const MAX_GENERATED_SIDE: usize = 16384;

/// The source a recipe describes, its parameters checked.
pub fn from_recipe(r: &Recipe) -> Result<Arc<dyn ExemplarSource>> {
    let bad = |m: String| TerrainError::Invalid { path: format!("generator '{}'", r.generator).into(), message: m };
    match r.generator.as_str() {
        "fbm" => {
            let f: Fbm = serde_json::from_value(r.params.clone()).map_err(|e| bad(format!("parameters: {e}")))?;
            f.check().map_err(bad)?;
            Ok(Arc::new(f))
        }
        other => Err(bad(format!("'{other}' is not a generator (known: fbm)"))),
    }
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

/// Fractional Brownian motion of value noise (see the module header).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Fbm {
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
}

impl Fbm {
    /// Refuses parameters that make no terrain or too large a one.
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
        Ok(())
    }

    /// The recipe of this generator.
    pub fn recipe(&self) -> Recipe {
        Recipe { generator: "fbm".into(), params: serde_json::to_value(self).unwrap_or_default() }
    }

    /// The heights at the generator's own cell size.
    pub fn generate(&self) -> Heightfield {
        let mut raw = vec![0f64; self.width * self.height];
        let (mut freq, mut amp) = (1.0 / self.wavelength_cells, 1.0);
        for octave in 0..self.octaves {
            let salt = self.seed ^ (octave as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
            for (i, v) in raw.iter_mut().enumerate() {
                let (x, y) = ((i % self.width) as f64 * freq, (i / self.width) as f64 * freq);
                *v += amp * value_noise(x, y, salt);
            }
            freq *= self.lacunarity;
            amp *= self.gain;
        }
        let (lo, hi) = raw.iter().fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
        let span = (hi - lo).max(1e-12);
        let data = raw.iter().map(|&v| (self.base_m + (v - lo) / span * self.relief_m) as f32).collect();
        Grid::from_vec(self.width, self.height, data)
    }
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

impl ExemplarSource for Fbm {
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

    fn fbm() -> Fbm {
        Fbm {
            name: "hills".into(),
            width: 96,
            height: 80,
            cell_size_m: 90.0,
            seed: 7,
            wavelength_cells: 32.0,
            octaves: 5,
            gain: 0.5,
            lacunarity: 2.0,
            relief_m: 1200.0,
            base_m: 300.0,
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
        let other = Fbm { seed: 8, ..fbm() }.generate();
        assert!(other.data.iter().zip(&a.data).filter(|(x, y)| (*x - *y).abs() > 50.0).count() > a.data.len() / 4);
        assert_ne!(f.identity(Some(90.0)).unwrap(), Fbm { seed: 8, ..fbm() }.identity(Some(90.0)).unwrap());
        // resampled like a DEM to another cell size
        assert_eq!(f.heights(Some(45.0), 4096).unwrap().width, 192);
    }

    #[test]
    fn bad_recipes_are_refused_with_the_reason() {
        let e = |r: Recipe| from_recipe(&r).unwrap_err().to_string();
        assert!(e(Recipe { generator: "plasma".into(), params: serde_json::json!({}) }).contains("not a generator"));
        let mut r = fbm().recipe();
        r.params["octaves"] = serde_json::json!(40);
        assert!(e(r).contains("octaves"));
        let mut r = fbm().recipe();
        r.params["width"] = serde_json::json!(1_000_000);
        assert!(e(r).contains("16384"));
        let mut r = fbm().recipe();
        r.params["colour"] = serde_json::json!("red");
        assert!(e(r).contains("colour"));
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
