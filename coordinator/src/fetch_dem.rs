//! `ridgeline fetch-dem`: real elevation data for a machine without a DEM library.
//! Downloads the open Terrarium elevation tiles (256 x 256 Web-Mercator PNG tiles,
//! `height = R * 256 + G + B / 256 - 32768` metres) covering a bounding box or a
//! named area into a tile cache, mosaics and crops them, and writes the result as a
//! 32-bit float GeoTIFF-tagged exemplar plus a `manifest.toml` for `--exemplars`.
//!
//! Tiles come from a [`TileSource`]: HTTP with timeouts, bounded retries with backoff
//! and a size limit (`ureq`), or a local folder laid out `{z}/{x}/{y}.png` (an offline
//! mirror, and what the tests use with fixtures they encode themselves).

use ridgeline_terrain::grid::{Grid, Heightfield};
use ridgeline_terrain::outputs::write_heightfield_with_cell;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Default tile URL template (AWS open data "Terrain Tiles", Terrarium encoding).
pub const DEFAULT_URL: &str = "https://s3.amazonaws.com/elevation-tiles-prod/terrarium/{z}/{x}/{y}.png";
const TILE: usize = 256;
const MAX_TILE_BYTES: u64 = 8 << 20;

/// Errors of fetch-dem.
#[derive(Debug, thiserror::Error)]
pub enum FetchError {
    #[error("bad area: {0}")]
    Area(String),
    #[error("tile {z}/{x}/{y}: {message}")]
    Tile { z: u32, x: u32, y: u32, message: String },
    #[error("{0} tiles needed, more than the limit of {1} (use a smaller area or zoom)")]
    TooManyTiles(usize, usize),
    #[error(transparent)]
    Terrain(#[from] ridgeline_terrain::TerrainError),
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
}

/// A lon/lat bounding box (degrees).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BBox {
    pub west: f64,
    pub south: f64,
    pub east: f64,
    pub north: f64,
}

/// Named areas with varied relief.
pub const AREAS: [(&str, BBox); 8] = [
    ("alps", BBox { west: 7.6, south: 45.8, east: 8.1, north: 46.1 }),
    ("rockies", BBox { west: -106.0, south: 39.4, east: -105.5, north: 39.8 }),
    ("himalaya", BBox { west: 86.7, south: 27.8, east: 87.2, north: 28.2 }),
    ("andes", BBox { west: -70.2, south: -32.8, east: -69.8, north: -32.5 }),
    ("appalachians", BBox { west: -83.7, south: 35.4, east: -83.2, north: 35.8 }),
    ("highlands", BBox { west: -5.3, south: 56.7, east: -4.8, north: 57.0 }),
    ("grand-canyon", BBox { west: -112.4, south: 36.0, east: -111.9, north: 36.3 }),
    ("norway", BBox { west: 6.8, south: 61.0, east: 7.4, north: 61.3 }),
];

impl BBox {
    /// Parses `west,south,east,north`.
    pub fn parse(s: &str) -> Result<BBox, FetchError> {
        let v: Vec<f64> = s
            .split(',')
            .map(|t| t.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| FetchError::Area(format!("'{s}': expected four numbers west,south,east,north")))?;
        let [west, south, east, north] = v[..] else {
            return Err(FetchError::Area(format!("'{s}': expected four numbers west,south,east,north")));
        };
        let b = BBox { west, south, east, north };
        let lon_ok = |v: f64| (-180.0..=180.0).contains(&v);
        let lat_ok = |v: f64| (-85.0..=85.0).contains(&v);
        let valid = west < east && south < north && lon_ok(west) && lon_ok(east) && lat_ok(south) && lat_ok(north);
        if !valid {
            return Err(FetchError::Area(format!("'{s}': need west < east, south < north, latitudes within ±85°")));
        }
        Ok(b)
    }

    /// A named area.
    pub fn named(name: &str) -> Result<BBox, FetchError> {
        AREAS.iter().find(|(n, _)| n.eq_ignore_ascii_case(name)).map(|(_, b)| *b).ok_or_else(|| {
            FetchError::Area(format!(
                "unknown area '{name}' (known: {})",
                AREAS.iter().map(|a| a.0).collect::<Vec<_>>().join(", ")
            ))
        })
    }
}

/// Global Web-Mercator pixel coordinates of a lon/lat at zoom `z`.
pub fn lonlat_to_pixel(lon: f64, lat: f64, z: u32) -> (f64, f64) {
    let n = (TILE as f64) * (1u64 << z) as f64;
    let x = (lon + 180.0) / 360.0 * n;
    let lr = lat.to_radians();
    let y = (1.0 - (lr.tan() + 1.0 / lr.cos()).ln() / std::f64::consts::PI) / 2.0 * n;
    (x, y)
}

/// Ground size of a pixel at latitude `lat` and zoom `z`, in metres.
pub fn cell_size_m(lat: f64, z: u32) -> f64 {
    156_543.033_92 * lat.to_radians().cos() / (1u64 << z) as f64
}

/// Decodes a Terrarium PNG tile to metres.
pub fn decode_terrarium(bytes: &[u8]) -> Result<Heightfield, String> {
    let img = image::load_from_memory_with_format(bytes, image::ImageFormat::Png).map_err(|e| e.to_string())?;
    let rgb = img.to_rgb8();
    let (w, h) = (rgb.width() as usize, rgb.height() as usize);
    if w != TILE || h != TILE {
        return Err(format!("tile is {w} x {h}, expected 256 x 256"));
    }
    let data = rgb.pixels().map(|p| (p[0] as f32 * 256.0 + p[1] as f32 + p[2] as f32 / 256.0) - 32768.0).collect();
    Ok(Grid::from_vec(w, h, data))
}

/// Encodes metres as a Terrarium PNG tile (for fixtures and mirrors).
pub fn encode_terrarium(h: &Heightfield) -> Vec<u8> {
    let mut img = image::RgbImage::new(h.width as u32, h.height as u32);
    for (i, p) in img.pixels_mut().enumerate() {
        let v = (h.data[i] + 32768.0).clamp(0.0, 65535.996);
        let r = (v / 256.0).floor();
        let g = (v - r * 256.0).floor();
        let b = ((v - r * 256.0 - g) * 256.0).round().min(255.0);
        *p = image::Rgb([r as u8, g as u8, b as u8]);
    }
    let mut buf = std::io::Cursor::new(Vec::new());
    img.write_to(&mut buf, image::ImageFormat::Png).expect("png encoding into memory");
    buf.into_inner()
}

/// Where tiles come from.
pub trait TileSource {
    fn fetch(&self, z: u32, x: u32, y: u32) -> Result<Vec<u8>, String>;
}

/// A local folder `{z}/{x}/{y}.png`.
pub struct DirSource(pub PathBuf);

impl TileSource for DirSource {
    fn fetch(&self, z: u32, x: u32, y: u32) -> Result<Vec<u8>, String> {
        let p = self.0.join(format!("{z}/{x}/{y}.png"));
        std::fs::read(&p).map_err(|e| format!("{}: {e}", p.display()))
    }
}

/// HTTP(S) with a URL template containing `{z}`, `{x}`, `{y}`.
pub struct HttpSource {
    pub template: String,
    agent: ureq::Agent,
}

impl HttpSource {
    pub fn new(template: &str) -> Self {
        let agent = ureq::AgentBuilder::new().timeout_connect(Duration::from_secs(15)).timeout(Duration::from_secs(60)).build();
        HttpSource { template: template.to_string(), agent }
    }
}

impl TileSource for HttpSource {
    fn fetch(&self, z: u32, x: u32, y: u32) -> Result<Vec<u8>, String> {
        let url = self.template.replace("{z}", &z.to_string()).replace("{x}", &x.to_string()).replace("{y}", &y.to_string());
        let mut last = String::new();
        for attempt in 0..4u32 {
            if attempt > 0 {
                std::thread::sleep(Duration::from_millis(500 * (1 << attempt)));
            }
            match self.agent.get(&url).call() {
                Ok(resp) => {
                    let mut buf = Vec::new();
                    resp.into_reader().take(MAX_TILE_BYTES + 1).read_to_end(&mut buf).map_err(|e| format!("{url}: {e}"))?;
                    if buf.len() as u64 > MAX_TILE_BYTES {
                        return Err(format!("{url}: larger than {MAX_TILE_BYTES} bytes"));
                    }
                    return Ok(buf);
                }
                Err(ureq::Error::Status(code, _)) if code < 500 && code != 429 => return Err(format!("{url}: HTTP {code}")),
                Err(e) => last = e.to_string(),
            }
        }
        Err(last)
    }
}

/// Fetches (through the cache folder) and mosaics the tiles of `bbox` at zoom `z`,
/// cropped to the box. Returns the heights and their cell size in metres.
pub fn fetch_area(
    bbox: BBox,
    z: u32,
    source: &dyn TileSource,
    cache: &Path,
    max_tiles: usize,
) -> Result<(Heightfield, f64), FetchError> {
    if z > 15 {
        return Err(FetchError::Area(format!("zoom {z} is above the tiles' maximum of 15")));
    }
    let (x0, y0) = lonlat_to_pixel(bbox.west, bbox.north, z);
    let (x1, y1) = lonlat_to_pixel(bbox.east, bbox.south, z);
    let (px0, py0, px1, py1) = (x0.floor() as usize, y0.floor() as usize, x1.ceil() as usize, y1.ceil() as usize);
    let (tx0, ty0, tx1, ty1) = (px0 / TILE, py0 / TILE, (px1 - 1) / TILE, (py1 - 1) / TILE);
    let count = (tx1 - tx0 + 1) * (ty1 - ty0 + 1);
    if count > max_tiles {
        return Err(FetchError::TooManyTiles(count, max_tiles));
    }
    let (w, h) = (px1 - px0, py1 - py0);
    let mut out = Grid::new(w, h, f32::NAN);
    for ty in ty0..=ty1 {
        for tx in tx0..=tx1 {
            let (zx, zy) = (tx as u32, ty as u32);
            let cached = cache.join(format!("terrarium/{z}/{zx}/{zy}.png"));
            let bytes = match std::fs::read(&cached) {
                Ok(b) => b,
                Err(_) => {
                    let b = source.fetch(z, zx, zy).map_err(|m| FetchError::Tile { z, x: zx, y: zy, message: m })?;
                    if let Some(parent) = cached.parent() {
                        std::fs::create_dir_all(parent).map_err(|e| FetchError::Io { path: parent.to_path_buf(), source: e })?;
                    }
                    ridgeline_terrain::io::write_atomic(&cached, &b)?;
                    b
                }
            };
            let tile = decode_terrarium(&bytes).map_err(|m| FetchError::Tile { z, x: zx, y: zy, message: m })?;
            for j in 0..TILE {
                let gy = ty * TILE + j;
                if gy < py0 || gy >= py1 {
                    continue;
                }
                for i in 0..TILE {
                    let gx = tx * TILE + i;
                    if gx >= px0 && gx < px1 {
                        out.set(gx - px0, gy - py0, tile.get(i, j));
                    }
                }
            }
        }
    }
    let cell = cell_size_m((bbox.south + bbox.north) / 2.0, z);
    Ok((out, cell))
}

/// Writes a fetched area as `{out}/{name}.tif` and a `{out}/manifest.toml` listing it.
pub fn write_exemplar(out_dir: &Path, name: &str, h: &Heightfield, cell: f64) -> Result<PathBuf, FetchError> {
    std::fs::create_dir_all(out_dir).map_err(|e| FetchError::Io { path: out_dir.to_path_buf(), source: e })?;
    let file = format!("{name}.tif");
    write_heightfield_with_cell(&out_dir.join(&file), h, Some(cell as f32))?;
    let manifest = out_dir.join("manifest.toml");
    let mut text = std::fs::read_to_string(&manifest).unwrap_or_default();
    if !text.contains(&format!("file = \"{file}\"")) {
        text.push_str(&format!("[[exemplar]]\nfile = \"{file}\"\ncell_size_m = {cell:.3}\nunit = \"metres\"\n\n"));
    }
    ridgeline_terrain::io::write_atomic(&manifest, text.as_bytes())?;
    Ok(manifest)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn elevation(gx: usize, gy: usize) -> f32 {
        // a smooth known surface over global pixel coordinates, in metres
        1200.0 + 800.0 * ((gx as f32) * 0.013).sin() * ((gy as f32) * 0.011).cos() + (gx % 7) as f32 * 0.25
    }

    #[test]
    fn terrarium_round_trip_is_within_a_256th_of_a_metre() {
        let h = Grid::from_vec(256, 256, (0..65536).map(|i| elevation(i % 256, i / 256) - 1500.0).collect());
        let back = decode_terrarium(&encode_terrarium(&h)).unwrap();
        for (a, b) in back.data.iter().zip(&h.data) {
            assert!((a - b).abs() <= 1.0 / 256.0 + 1e-3, "{a} vs {b}");
        }
        assert!(decode_terrarium(b"not a png").is_err());
    }

    #[test]
    fn mosaic_and_crop_from_an_offline_fixture() {
        let root = std::env::temp_dir().join(format!("rl-fetch-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let (tiles, cache) = (root.join("tiles"), root.join("cache"));
        let bbox = BBox { west: 7.6, south: 45.8, east: 8.1, north: 46.1 };
        let z = 10;
        let (x0, y0) = lonlat_to_pixel(bbox.west, bbox.north, z);
        let (x1, y1) = lonlat_to_pixel(bbox.east, bbox.south, z);
        // encode every tile the box touches from the known surface
        for ty in (y0 as usize / 256)..=((y1.ceil() as usize - 1) / 256) {
            for tx in (x0 as usize / 256)..=((x1.ceil() as usize - 1) / 256) {
                let t = Grid::from_vec(256, 256, (0..65536).map(|i| elevation(tx * 256 + i % 256, ty * 256 + i / 256)).collect());
                let p = tiles.join(format!("{z}/{tx}/{ty}.png"));
                std::fs::create_dir_all(p.parent().unwrap()).unwrap();
                std::fs::write(&p, encode_terrarium(&t)).unwrap();
            }
        }
        let (h, cell) = fetch_area(bbox, z, &DirSource(tiles.clone()), &cache, 64).unwrap();
        assert_eq!(h.width, x1.ceil() as usize - x0.floor() as usize);
        for y in 0..h.height {
            for x in 0..h.width {
                let want = elevation(x0.floor() as usize + x, y0.floor() as usize + y);
                assert!((h.get(x, y) - want).abs() <= 0.01, "({x},{y})");
            }
        }
        assert!((cell - 152.87 * (45.95f64).to_radians().cos() / 1.0).abs() < 1.0, "cell {cell}");
        // a second fetch is served from the cache even without the source
        std::fs::remove_dir_all(&tiles).unwrap();
        assert_eq!(fetch_area(bbox, z, &DirSource(tiles), &cache, 64).unwrap().0, h);
        assert!(matches!(fetch_area(bbox, z, &DirSource(root.join("none")), &cache, 1), Err(FetchError::TooManyTiles(..))));
        let m = write_exemplar(&root.join("lib"), "alps", &h, cell).unwrap();
        let specs = ridgeline_terrain::library::scan_library(&m).unwrap();
        let back = ridgeline_terrain::library::load_exemplar(&specs[0], Some(cell as f32), 4096).unwrap();
        assert_eq!(back, h);
    }

    #[test]
    fn bad_boxes_and_names_are_refused() {
        assert!(BBox::parse("1,2,3").is_err());
        assert!(BBox::parse("8,46,7,47").is_err());
        assert!(BBox::parse("a,b,c,d").is_err());
        assert!(BBox::named("atlantis").unwrap_err().to_string().contains("alps"));
        assert!(BBox::parse("7.6,45.8,8.1,46.1").is_ok());
    }
}
