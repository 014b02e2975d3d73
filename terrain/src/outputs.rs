//! Terrain outputs by extension, each written atomically:
//! - `.tif`: single-channel 32-bit float metres, with the GeoTIFF pixel-scale tag, and
//!   where a [`Georef`] is given a GeoTIFF: its model tie point and GeoKeys (a
//!   projected CRS by EPSG code, pixel-is-area), so GDAL and rasterio place it;
//! - `.png`: 16-bit, with a `.json` sidecar (`min_elevation`, `scale`, `unit`) that
//!   converts samples back to metres;
//! - `.r16`: raw little-endian 16-bit samples (as game engines import heightmaps),
//!   with the same sidecar; the sidecar also gives the cell size and the engine
//!   settings that reproduce the metres exactly (Unreal's landscape Z scale and
//!   location, Unity's terrain height and position);
//! - `.exr`: OpenEXR, one 32-bit float channel `Y` of metres, lossless (ZIP), the cell
//!   size in a `cellSizeMetres` attribute (written with the `exr` crate);
//! - tiles: N x N-sample tiles sharing their border row and column with the next tile
//!   (the layout Unreal and Unity landscape imports expect), named
//!   `{stem}_x{col}_y{row}.{ext}`, with a `{stem}_tiles.json` index; 16-bit tiles all
//!   use the whole terrain's range so they join without steps.

use crate::dem_formats::parse_tiff;
use crate::error::{Result, TerrainError};
use crate::grid::{Grid, Heightfield};
use crate::io::{write_atomic, write_atomic_with};
use std::path::{Path, PathBuf};

/// Sidecar of 16-bit outputs: `metres = min_elevation + sample * scale`, and what an
/// engine import needs to reproduce those metres.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize, PartialEq)]
pub struct Png16Sidecar {
    pub min_elevation: f64,
    pub max_elevation: f64,
    pub unit: String,
    pub width: usize,
    pub height: usize,
    pub scale: f64,
    /// Horizontal cell size in metres, where known.
    #[serde(default)]
    pub cell_size_m: Option<f64>,
    /// Unreal Engine landscape import: the actor's scale and location that give these
    /// metres (`metres = (sample - 32768) * z_scale / 12800 + location_z / 100`).
    #[serde(default)]
    pub unreal: Option<UnrealLandscape>,
    /// Unity terrain import: `metres = sample / 65535 * terrain_height + position_y`.
    #[serde(default)]
    pub unity: Option<UnityTerrain>,
}

/// An Unreal landscape actor's transform for a 16-bit heightmap (centimetres).
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize, PartialEq)]
pub struct UnrealLandscape {
    /// Landscape scale X and Y: one quad per cell.
    pub xy_scale: f64,
    /// Landscape scale Z: a sample step is `z_scale / 128` cm.
    pub z_scale: f64,
    /// Landscape location Z, where sample 32768 stands.
    pub location_z: f64,
}

/// A Unity terrain's settings for a 16-bit heightmap (metres).
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize, PartialEq)]
pub struct UnityTerrain {
    /// `TerrainData.size.x` and `.z`: the terrain's extent (`(cells - 1) * cell`).
    pub width: f64,
    pub length: f64,
    /// `TerrainData.size.y`: the height sample 65535 reaches above the position.
    pub terrain_height: f64,
    /// The terrain object's position y: where sample 0 stands.
    pub position_y: f64,
}

impl Png16Sidecar {
    /// The mapping for a heightfield's own range.
    pub fn for_range(lo: f32, hi: f32, width: usize, height: usize) -> Self {
        let span = (hi - lo) as f64;
        let scale = if span > 0.0 { span / 65535.0 } else { 1.0 };
        let min = lo as f64;
        Png16Sidecar {
            min_elevation: min,
            max_elevation: hi as f64,
            unit: "m".into(),
            width,
            height,
            scale,
            cell_size_m: None,
            unreal: Some(UnrealLandscape {
                xy_scale: 100.0,
                z_scale: scale * 12_800.0,
                location_z: (min + 32_768.0 * scale) * 100.0,
            }),
            unity: Some(UnityTerrain {
                width: (width.max(1) - 1) as f64,
                length: (height.max(1) - 1) as f64,
                terrain_height: scale * 65_535.0,
                position_y: min,
            }),
        }
    }

    /// The same mapping, with the horizontal cell size (metres) where known.
    pub fn with_cell(mut self, cell: Option<f32>) -> Self {
        let c = cell.map(|c| c as f64);
        self.cell_size_m = c;
        let c = c.unwrap_or(1.0);
        if let Some(u) = &mut self.unreal {
            u.xy_scale = c * 100.0;
        }
        if let Some(u) = &mut self.unity {
            u.width = (self.width.max(1) - 1) as f64 * c;
            u.length = (self.height.max(1) - 1) as f64 * c;
        }
        self
    }
    pub fn quantise(&self, v: f32) -> u16 {
        (((v as f64 - self.min_elevation) / self.scale).round()).clamp(0.0, 65535.0) as u16
    }
    pub fn metres(&self, s: u16) -> f32 {
        (self.min_elevation + s as f64 * self.scale) as f32
    }
}

/// Where a terrain lies: a projected coordinate system (EPSG code, units metres) and
/// the CRS coordinates of its top-left cell's top-left corner.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Georef {
    pub epsg: u16,
    pub origin: [f64; 2],
}

impl Georef {
    /// From `EPSG:CODE` and `X,Y`; refused, saying why, for a geographic CRS (the
    /// terrain's cells are metres), a code GeoTIFF cannot carry, or coordinates that
    /// are not two finite numbers.
    pub fn parse(crs: &str, origin: &str) -> std::result::Result<Georef, String> {
        let code = crs.trim().strip_prefix("EPSG:").or_else(|| crs.trim().strip_prefix("epsg:")).unwrap_or(crs.trim());
        let epsg: u16 = code.parse().map_err(|_| format!("CRS '{crs}': give EPSG:CODE, such as EPSG:32633 (UTM zone 33N)"))?;
        if (4000..5000).contains(&epsg) {
            return Err(format!(
                "CRS EPSG:{epsg} is geographic (degrees), and the terrain's cells are metres: give a projected CRS in metres, such as a UTM zone (EPSG:326xx or 327xx)"
            ));
        }
        if !(1024..=32766).contains(&epsg) {
            return Err(format!("CRS EPSG:{epsg}: GeoTIFF carries projected EPSG codes 1024 to 32766"));
        }
        let xy: Vec<f64> = origin
            .split(',')
            .map(|v| v.trim().parse::<f64>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| format!("origin '{origin}': give X,Y, the CRS coordinates of the top-left corner"))?;
        match xy[..] {
            [x, y] if x.is_finite() && y.is_finite() => Ok(Georef { epsg, origin: [x, y] }),
            _ => Err(format!("origin '{origin}': give two finite numbers X,Y")),
        }
    }

    /// The same place, `dx` cells right and `dy` cells down (a tile's origin).
    pub fn shifted(&self, dx: usize, dy: usize, cell: f32) -> Georef {
        Georef { epsg: self.epsg, origin: [self.origin[0] + dx as f64 * cell as f64, self.origin[1] - dy as f64 * cell as f64] }
    }
}

fn other(path: &Path, e: impl std::fmt::Display) -> TerrainError {
    TerrainError::Other(format!("{}: {e}", path.display()))
}

/// Encodes a heightfield as a single-channel 32-bit float TIFF; `cell` (metres)
/// goes into the GeoTIFF pixel-scale tag.
pub fn encode_tiff_f32_with_cell(h: &Heightfield, cell: Option<f32>) -> Result<Vec<u8>> {
    let mut buf = std::io::Cursor::new(Vec::new());
    write_tiff_f32(&mut buf, h, cell).map_err(|e| TerrainError::Other(e.to_string()))?;
    Ok(buf.into_inner())
}

/// Streams a heightfield as a single-channel 32-bit float TIFF into `w` (strip by
/// strip: no second copy of the terrain in memory).
pub fn write_tiff_f32<W: std::io::Write + std::io::Seek>(w: &mut W, h: &Heightfield, cell: Option<f32>) -> std::io::Result<()> {
    write_tiff_f32_as(w, h, cell, None, needs_bigtiff(h))
}

/// [`write_tiff_f32`] as a GeoTIFF placed by `geo` (with `cell` its pixel size).
pub fn write_geotiff_f32<W: std::io::Write + std::io::Seek>(
    w: &mut W,
    h: &Heightfield,
    cell: Option<f32>,
    geo: Option<&Georef>,
) -> std::io::Result<()> {
    write_tiff_f32_as(w, h, cell, geo, needs_bigtiff(h))
}

/// Pixel bytes above which a float TIFF is written as BigTIFF: classic TIFF holds
/// 32-bit offsets, so a terrain above about 32000² (4 GiB of samples) cannot be one.
/// Below it the classic format is kept, which more tools read.
pub const BIGTIFF_ABOVE_BYTES: u64 = (u32::MAX as u64) - (256 << 20);

fn needs_bigtiff(h: &Heightfield) -> bool {
    (h.data.len() as u64) * 4 > BIGTIFF_ABOVE_BYTES
}

fn write_tiff_f32_as<W: std::io::Write + std::io::Seek>(
    w: &mut W,
    h: &Heightfield,
    cell: Option<f32>,
    geo: Option<&Georef>,
    big: bool,
) -> std::io::Result<()> {
    use tiff::encoder::{colortype::Gray32Float, TiffEncoder, TiffKind};
    fn write<W: std::io::Write + std::io::Seek, K: TiffKind>(
        enc: &mut TiffEncoder<W, K>,
        h: &Heightfield,
        cell: Option<f32>,
        geo: Option<&Georef>,
    ) -> tiff::TiffResult<()> {
        let mut img = enc.new_image::<Gray32Float>(h.width as u32, h.height as u32)?;
        if let Some(c) = cell {
            let scale = [c as f64, c as f64, 0.0];
            img.encoder().write_tag(tiff::tags::Tag::ModelPixelScaleTag, &scale[..])?;
        }
        if let Some(g) = geo {
            // raster (0, 0) at the CRS origin; GeoKeys (GeoTIFF 1.0, sorted by key):
            // model type projected, raster pixel-is-area, the projected CRS, metres
            let tie = [0.0, 0.0, 0.0, g.origin[0], g.origin[1], 0.0];
            img.encoder().write_tag(tiff::tags::Tag::ModelTiepointTag, &tie[..])?;
            let keys: [u16; 20] = [1, 1, 0, 4, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, g.epsg, 3076, 0, 1, 9001];
            img.encoder().write_tag(tiff::tags::Tag::GeoKeyDirectoryTag, &keys[..])?;
        }
        img.write_data(&h.data)
    }
    let result = if big {
        TiffEncoder::new_big(w).and_then(|mut enc| write(&mut enc, h, cell, geo))
    } else {
        TiffEncoder::new(w).and_then(|mut enc| write(&mut enc, h, cell, geo))
    };
    result.map_err(|e| std::io::Error::other(e.to_string()))
}

/// Encodes a heightfield as a single-channel 32-bit float TIFF.
pub fn encode_tiff_f32(h: &Heightfield) -> Result<Vec<u8>> {
    encode_tiff_f32_with_cell(h, None)
}

/// Name of the EXR attribute holding the cell size in metres.
pub const EXR_CELL_ATTRIBUTE: &str = "cellSizeMetres";

/// Streams a heightfield as a one-channel (`Y`) 32-bit float OpenEXR, ZIP-compressed
/// (lossless), into `w`.
pub fn write_exr_f32<W: std::io::Write + std::io::Seek>(w: &mut W, h: &Heightfield, cell: Option<f32>) -> std::io::Result<()> {
    use exr::prelude::*;
    let channels = SpecificChannels::build().with_channel("Y").with_pixel_fn(|p: Vec2<usize>| (h.data[p.y() * h.width + p.x()],));
    let mut attributes = LayerAttributes::named("terrain");
    if let Some(c) = cell {
        attributes.other.insert(Text::from(EXR_CELL_ATTRIBUTE), AttributeValue::F32(c));
    }
    let layer = Layer::new((h.width, h.height), attributes, Encoding::SMALL_LOSSLESS, channels);
    Image::from_layer(layer).write().non_parallel().to_buffered(w).map_err(|e| std::io::Error::other(e.to_string()))
}

/// Reads a one-channel float OpenEXR written by [`write_exr_f32`] (or any with a `Y`
/// channel, or a single channel) as metres, with its cell size if it records one.
pub fn parse_exr(path: &Path, bytes: &[u8], max_side: u32) -> Result<(Heightfield, Option<f32>)> {
    use exr::prelude::*;
    let bad = |m: String| TerrainError::Invalid { path: path.to_path_buf(), message: m };
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .non_parallel()
        .from_buffered(std::io::Cursor::new(bytes))
        .map_err(|e| bad(format!("not a readable OpenEXR: {e}")))?;
    let layer = &image.layer_data;
    let (w, h) = (layer.size.width(), layer.size.height());
    crate::dem_formats::check_size(path, w as u64, h as u64, max_side)?;
    let list = &layer.channel_data.list;
    let channel = list
        .iter()
        .find(|c| c.name.eq("Y"))
        .or(if list.len() == 1 { list.first() } else { None })
        .ok_or_else(|| bad(format!("{} channels and none named Y: give a one-channel EXR", list.len())))?;
    let data: Vec<f32> = match &channel.sample_data {
        FlatSamples::F32(v) => v.clone(),
        FlatSamples::F16(v) => v.iter().map(|x| x.to_f32()).collect(),
        FlatSamples::U32(v) => v.iter().map(|&x| x as f32).collect(),
    };
    let cell = match layer.attributes.other.get(&Text::from(EXR_CELL_ATTRIBUTE)) {
        Some(AttributeValue::F32(c)) if c.is_finite() && *c > 0.0 => Some(*c),
        _ => None,
    };
    Ok((Grid::from_vec(w, h, data), cell))
}

fn encode_png16(path: &Path, h: &Heightfield, side: &Png16Sidecar) -> Result<Vec<u8>> {
    let samples: Vec<u16> = h.data.iter().map(|&v| side.quantise(v)).collect();
    let img = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(h.width as u32, h.height as u32, samples)
        .ok_or_else(|| other(path, "png buffer size mismatch"))?;
    let mut buf = std::io::Cursor::new(Vec::new());
    img.write_to(&mut buf, image::ImageFormat::Png).map_err(|e| other(path, e))?;
    Ok(buf.into_inner())
}

fn ext_of(path: &Path) -> String {
    path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default()
}

/// Output extensions [`write_heightfield`] accepts.
pub const OUTPUT_EXTENSIONS: [&str; 5] = ["tif", "tiff", "png", "r16", "exr"];

/// The `.json` sidecar a 16-bit output (`.png`, `.r16`) is written with; `None` for
/// formats that carry metres themselves.
pub fn sidecar_path(path: &Path) -> Option<PathBuf> {
    matches!(ext_of(path).as_str(), "png" | "r16").then(|| path.with_extension("json"))
}

/// Every file [`write_heightfield`] writes for `path`: the file and its sidecar.
pub fn heightfield_files(path: &Path) -> Vec<PathBuf> {
    std::iter::once(path.to_path_buf()).chain(sidecar_path(path)).collect()
}

fn write_with_sidecar(path: &Path, h: &Heightfield, side: &Png16Sidecar, cell: Option<f32>, geo: Option<&Georef>) -> Result<()> {
    let ext = ext_of(path);
    match ext.as_str() {
        "tif" | "tiff" => write_atomic_with(path, |f| write_geotiff_f32(f, h, cell, geo)),
        "exr" => write_atomic_with(path, |f| write_exr_f32(f, h, cell)),
        "png" | "r16" => {
            let side = side.clone().with_cell(cell);
            let json = serde_json::to_vec_pretty(&side).map_err(|e| other(path, e))?;
            write_atomic(&path.with_extension("json"), &json)?;
            if ext == "png" {
                write_atomic(path, &encode_png16(path, h, &side)?)
            } else {
                write_atomic_with(path, |f| {
                    use std::io::Write;
                    for row in h.data.chunks(h.width.max(1)) {
                        let bytes: Vec<u8> = row.iter().flat_map(|&v| side.quantise(v).to_le_bytes()).collect();
                        f.write_all(&bytes)?;
                    }
                    Ok(())
                })
            }
        }
        _ => Err(TerrainError::Invalid {
            path: path.to_path_buf(),
            message: format!("unsupported output extension (use {})", OUTPUT_EXTENSIONS.join(", ")),
        }),
    }
}

/// Writes a heightfield by extension (see the module header).
pub fn write_heightfield(path: &Path, h: &Heightfield) -> Result<()> {
    write_heightfield_with_cell(path, h, None)
}

/// [`write_heightfield`], recording the cell size where the format can.
pub fn write_heightfield_with_cell(path: &Path, h: &Heightfield, cell: Option<f32>) -> Result<()> {
    write_heightfield_geo(path, h, cell, None)
}

/// [`write_heightfield_with_cell`], a TIFF placed by `geo` as a GeoTIFF.
pub fn write_heightfield_geo(path: &Path, h: &Heightfield, cell: Option<f32>, geo: Option<&Georef>) -> Result<()> {
    let (lo, hi) = h.finite_range().unwrap_or((0.0, 0.0));
    write_with_sidecar(path, h, &Png16Sidecar::for_range(lo, hi, h.width, h.height), cell, geo)
}

fn read_sidecar(path: &Path) -> Result<Png16Sidecar> {
    let sp = path.with_extension("json");
    let bytes = crate::io::read_input(&sp, crate::io::MAX_TEXT_BYTES)?;
    serde_json::from_slice(&bytes).map_err(|e| TerrainError::Invalid { path: sp, message: format!("bad sidecar: {e}") })
}

/// Reads back an output written by [`write_heightfield`] (metres).
pub fn read_heightfield(path: &Path, max_side: u32) -> Result<Heightfield> {
    match ext_of(path).as_str() {
        "tif" | "tiff" => {
            let bytes = crate::io::read_input(path, crate::io::raster_byte_limit(max_side))?;
            Ok(parse_tiff(path, &bytes, max_side)?.heights)
        }
        "exr" => {
            let bytes = crate::io::read_input(path, crate::io::raster_byte_limit(max_side))?;
            Ok(parse_exr(path, &bytes, max_side)?.0)
        }
        "png" => {
            let side = read_sidecar(path)?;
            let raw = crate::io::read_dem_png(path, max_side)?;
            Ok(raw.map(|v| side.metres(v as u16)))
        }
        "r16" => {
            let side = read_sidecar(path)?;
            let bytes = crate::io::read_input(path, crate::io::raster_byte_limit(max_side))?;
            if bytes.len() != side.width * side.height * 2 {
                return Err(TerrainError::Invalid {
                    path: path.to_path_buf(),
                    message: format!("{} bytes, sidecar says {} x {}", bytes.len(), side.width, side.height),
                });
            }
            let data = bytes.chunks_exact(2).map(|c| side.metres(u16::from_le_bytes([c[0], c[1]]))).collect();
            Ok(Grid::from_vec(side.width, side.height, data))
        }
        _ => Err(TerrainError::Invalid { path: path.to_path_buf(), message: "unsupported extension".into() }),
    }
}

/// One tile in the tile index.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize, PartialEq)]
pub struct TileEntry {
    pub file: String,
    pub col: usize,
    pub row: usize,
    /// Terrain cell of the tile's first sample.
    pub x0: usize,
    pub y0: usize,
    /// Samples of the tile that lie inside the terrain (the rest repeat its edge).
    pub valid_width: usize,
    pub valid_height: usize,
}

/// The `{stem}_tiles.json` index.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize, PartialEq)]
pub struct TileIndex {
    pub tile_size: usize,
    /// Distance between tile origins: `tile_size - 1` (shared border).
    pub stride: usize,
    pub columns: usize,
    pub rows: usize,
    pub width: usize,
    pub height: usize,
    /// For 16-bit tiles: the shared mapping to metres.
    pub elevation: Option<Png16Sidecar>,
    pub tiles: Vec<TileEntry>,
}

/// Where an `n x n`-sample tiling of a `width x height` terrain written as `out`
/// goes: `{stem}_x{col}_y{row}.{ext}` beside `out`, and the `{stem}_tiles.json` index.
#[derive(Debug, Clone)]
pub struct TilePlan {
    dir: PathBuf,
    stem: String,
    ext: String,
    pub n: usize,
    /// Distance between tile origins (`n - 1`: tiles share their border).
    pub stride: usize,
    pub columns: usize,
    pub rows: usize,
}

impl TilePlan {
    pub fn new(out: &Path, width: usize, height: usize, n: usize) -> Result<TilePlan> {
        // bounded by the terrain before it sizes anything (a tile's buffer, the files)
        let longest = width.max(height);
        if n < 2 || n > longest {
            return Err(TerrainError::Invalid {
                path: out.to_path_buf(),
                message: format!(
                    "tiles of {n} samples: a tile needs 2 to {} samples a side (the longer side of the {width} x {height} terrain)",
                    longest.max(2)
                ),
            });
        }
        let stride = n - 1;
        Ok(TilePlan {
            dir: out.parent().filter(|p| !p.as_os_str().is_empty()).map(Path::to_path_buf).unwrap_or_else(|| PathBuf::from(".")),
            stem: out.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "terrain".into()),
            ext: ext_of(out),
            n,
            stride,
            columns: width.saturating_sub(1).div_ceil(stride).max(1),
            rows: height.saturating_sub(1).div_ceil(stride).max(1),
        })
    }

    /// File name of the tile at (col, row).
    pub fn tile_name(&self, col: usize, row: usize) -> String {
        format!("{}_x{col}_y{row}.{}", self.stem, self.ext)
    }

    pub fn index_path(&self) -> PathBuf {
        self.dir.join(format!("{}_tiles.json", self.stem))
    }

    /// Every file the tiling writes: tiles, their sidecars, the index.
    pub fn files(&self) -> Vec<PathBuf> {
        let tiles = (0..self.rows).flat_map(|r| (0..self.columns).map(move |c| (c, r)));
        tiles.flat_map(|(c, r)| heightfield_files(&self.dir.join(self.tile_name(c, r)))).chain([self.index_path()]).collect()
    }

    /// Where the tiles do not fill the terrain exactly, a sentence saying what the last
    /// tiles hold (the rest of them repeats the edge) and the size that would fill them;
    /// `None` when every tile is filled.
    pub fn padding(&self, width: usize, height: usize) -> Option<String> {
        let fills = |side: usize| (side - 1).is_multiple_of(self.stride);
        if fills(width) && fills(height) {
            return None;
        }
        let fit = |side: usize| (side - 1).div_ceil(self.stride) * self.stride + 1;
        let last = |side: usize| (side - 1) % self.stride + 1;
        let below = |side: usize| ((side - 1) / self.stride).max(1) * self.stride + 1;
        Some(format!(
            "tiles of {n} do not fill a {width} x {height} terrain: the last column holds {} and the last row {} of {n} samples, the rest repeat the edge (the tile index gives each tile's valid size); a {} x {} terrain (--size) fills {} x {} tiles exactly, a {} x {} one {} x {}",
            if fills(width) { self.n } else { last(width) },
            if fills(height) { self.n } else { last(height) },
            fit(width),
            fit(height),
            self.columns,
            self.rows,
            below(width),
            below(height),
            (below(width) - 1) / self.stride,
            (below(height) - 1) / self.stride,
            n = self.n
        ))
    }

    /// How many files [`TilePlan::files`] lists, without listing them.
    pub fn file_count(&self) -> usize {
        let per_tile = heightfield_files(Path::new(&format!("t.{}", self.ext))).len();
        self.columns * self.rows * per_tile + 1
    }
}

/// Writes `h` as `n x n` tiles beside `out` in `out`'s format; returns the index path.
pub fn write_tiles(out: &Path, h: &Heightfield, n: usize, cell: Option<f32>) -> Result<PathBuf> {
    write_tiles_geo(out, h, n, cell, None)
}

/// [`write_tiles`], each TIFF tile a GeoTIFF placed where it lies in `geo`.
pub fn write_tiles_geo(out: &Path, h: &Heightfield, n: usize, cell: Option<f32>, geo: Option<&Georef>) -> Result<PathBuf> {
    let plan = TilePlan::new(out, h.width, h.height, n)?;
    let (lo, hi) = h.finite_range().unwrap_or((0.0, 0.0));
    let side = Png16Sidecar::for_range(lo, hi, n, n);
    let mut index = TileIndex {
        tile_size: n,
        stride: plan.stride,
        columns: plan.columns,
        rows: plan.rows,
        width: h.width,
        height: h.height,
        elevation: sidecar_path(out).map(|_| side.clone()),
        tiles: Vec::new(),
    };
    for row in 0..plan.rows {
        for col in 0..plan.columns {
            let (x0, y0) = (col * plan.stride, row * plan.stride);
            let mut t = Grid::new(n, n, 0f32);
            for j in 0..n {
                for i in 0..n {
                    t.set(i, j, h.get((x0 + i).min(h.width - 1), (y0 + j).min(h.height - 1)));
                }
            }
            let file = plan.tile_name(col, row);
            let tile_geo = geo.zip(cell).map(|(g, c)| g.shifted(x0, y0, c));
            write_with_sidecar(&plan.dir.join(&file), &t, &side, cell, tile_geo.as_ref())?;
            index.tiles.push(TileEntry {
                file,
                col,
                row,
                x0,
                y0,
                valid_width: n.min(h.width - x0),
                valid_height: n.min(h.height - y0),
            });
        }
    }
    let ip = plan.index_path();
    write_atomic(&ip, &serde_json::to_vec_pretty(&index).map_err(|e| other(&ip, e))?)?;
    Ok(ip)
}

/// Reassembles a terrain from a tile index written by [`write_tiles`].
pub fn read_tiles(index_path: &Path, max_side: u32) -> Result<Heightfield> {
    let bytes = crate::io::read_input(index_path, crate::io::MAX_TEXT_BYTES)?;
    let idx: TileIndex = serde_json::from_slice(&bytes)
        .map_err(|e| TerrainError::Invalid { path: index_path.to_path_buf(), message: format!("bad tile index: {e}") })?;
    crate::dem_formats::check_size(index_path, idx.width as u64, idx.height as u64, max_side)?;
    let dir = index_path.parent().unwrap_or(Path::new("."));
    let mut out = Grid::new(idx.width, idx.height, f32::NAN);
    for t in &idx.tiles {
        let tile = read_heightfield(&dir.join(&t.file), max_side)?;
        for j in 0..t.valid_height.min(tile.height) {
            for i in 0..t.valid_width.min(tile.width) {
                if t.x0 + i < idx.width && t.y0 + j < idx.height {
                    out.set(t.x0 + i, t.y0 + j, tile.get(i, j));
                }
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(w: usize, h: usize) -> Heightfield {
        Grid::from_vec(w, h, (0..w * h).map(|i| 100.0 + (i as f32 * 37.3).sin() * 250.0).collect())
    }

    fn tmp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("rl-out-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn bigtiff_output_reads_back_exactly() {
        // the format very large terrains are written in, checked at a small size
        let h = sample(29, 17);
        let mut buf = std::io::Cursor::new(Vec::new());
        write_tiff_f32_as(&mut buf, &h, Some(30.0), None, true).unwrap();
        let bytes = buf.into_inner();
        assert_eq!(&bytes[..4], b"II+\0", "BigTIFF header");
        let back = parse_tiff(Path::new("big.tif"), &bytes, 1000).unwrap();
        assert_eq!(back.cell_size_m, Some(30.0));
        assert_eq!(back.heights.data, h.data);
        assert!(!needs_bigtiff(&h) && needs_bigtiff(&Grid::new(33000, 33000, 0.0)));
    }

    #[test]
    fn every_output_format_round_trips() {
        let d = tmp("rt");
        let h = sample(37, 23);
        write_heightfield_with_cell(&d.join("t.tif"), &h, Some(90.0)).unwrap();
        assert_eq!(read_heightfield(&d.join("t.tif"), 1000).unwrap(), h, "tif is exact");
        let bytes = std::fs::read(d.join("t.tif")).unwrap();
        assert_eq!(parse_tiff(Path::new("t.tif"), &bytes, 1000).unwrap().cell_size_m, Some(90.0));
        for ext in ["png", "r16"] {
            let p = d.join(format!("t.{ext}"));
            write_heightfield(&p, &h).unwrap();
            let back = read_heightfield(&p, 1000).unwrap();
            let side = read_sidecar(&p).unwrap();
            for (a, b) in back.data.iter().zip(&h.data) {
                assert!((a - b).abs() as f64 <= side.scale * 0.5 + 1e-3, "{ext}: {a} vs {b}");
            }
        }
        assert!(write_heightfield(&d.join("t.jpg"), &h).is_err());
    }

    #[test]
    fn exr_round_trips_exactly_with_its_cell_size() {
        let d = tmp("exr");
        let h = Grid::from_vec(37, 23, (0..37 * 23).map(|i| (i as f32 * 0.731).sin() * 2500.0 + 1.0e-3 * i as f32).collect());
        let p = d.join("t.exr");
        write_heightfield_with_cell(&p, &h, Some(30.0)).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        let (back, cell) = parse_exr(&p, &bytes, 4096).unwrap();
        assert_eq!((back.width, back.height, cell), (37, 23, Some(30.0)));
        assert!(back.data.iter().zip(&h.data).all(|(a, b)| a.to_bits() == b.to_bits()), "bit for bit");
        assert_eq!(read_heightfield(&p, 4096).unwrap().data, h.data);
        std::fs::write(d.join("bad.exr"), b"v/1\x01 not an exr").unwrap();
        assert!(read_heightfield(&d.join("bad.exr"), 4096).unwrap_err().to_string().contains("bad.exr"));
    }

    #[test]
    fn sixteen_bit_sidecars_give_the_engine_settings_that_reproduce_the_metres() {
        let d = tmp("side");
        let h = Grid::from_vec(65, 33, (0..65 * 33).map(|i| 812.5 + (i % 97) as f32 * 31.25).collect());
        let p = d.join("t.r16");
        write_heightfield_with_cell(&p, &h, Some(12.5)).unwrap();
        let side: Png16Sidecar = serde_json::from_slice(&std::fs::read(d.join("t.json")).unwrap()).unwrap();
        assert_eq!(side.cell_size_m, Some(12.5));
        let (ue, unity) = (side.unreal.unwrap(), side.unity.unwrap());
        assert_eq!((ue.xy_scale, unity.width, unity.length), (1250.0, 800.0, 400.0));
        for s in [0u16, 1, 1000, 32767, 32768, 65534, 65535] {
            let want = side.min_elevation + s as f64 * side.scale;
            let unreal = (s as f64 - 32768.0) * ue.z_scale / 12800.0 + ue.location_z / 100.0;
            let unity_m = s as f64 / 65535.0 * unity.terrain_height + unity.position_y;
            assert!((unreal - want).abs() < 1e-9 && (unity_m - want).abs() < 1e-9, "{s}: {want} {unreal} {unity_m}");
        }
        assert!((side.metres(65535) - 812.5 - 96.0 * 31.25).abs() < 1e-3);
    }

    #[test]
    fn a_crs_is_projected_by_its_epsg_code_and_an_origin_two_numbers() {
        assert_eq!(Georef::parse("EPSG:32633", "500000, -12.5"), Ok(Georef { epsg: 32633, origin: [500000.0, -12.5] }));
        assert!(Georef::parse("EPSG:4326", "0,0").unwrap_err().contains("geographic"));
        assert!(Georef::parse("EPSG:99999", "0,0").unwrap_err().contains("EPSG:CODE"));
        assert!(Georef::parse("EPSG:500", "0,0").unwrap_err().contains("1024 to 32766"));
        assert!(Georef::parse("EPSG:32633", "1,2,3").unwrap_err().contains("two finite"));
        assert!(Georef::parse("EPSG:32633", "1,nan").unwrap_err().contains("two finite"));
        let g = Georef::parse("epsg:2056", "2600000,1200000").unwrap().shifted(256, 512, 2.0);
        assert_eq!(g.origin, [2600512.0, 1198976.0]);
        // the keys a GeoTIFF reader needs are in the file
        let d = tmp("geo");
        let h = Grid::from_vec(8, 8, vec![1.0f32; 64]);
        write_heightfield_geo(&d.join("g.tif"), &h, Some(2.0), Some(&g)).unwrap();
        let mut dec = tiff::decoder::Decoder::new(std::fs::File::open(d.join("g.tif")).unwrap()).unwrap();
        assert_eq!(dec.get_tag_f64_vec(tiff::tags::Tag::ModelTiepointTag).unwrap(), [0.0, 0.0, 0.0, 2600512.0, 1198976.0, 0.0]);
        let keys = dec.get_tag_u32_vec(tiff::tags::Tag::GeoKeyDirectoryTag).unwrap();
        assert_eq!(&keys[12..16], &[3072, 0, 1, 2056]);
    }

    #[test]
    fn tiles_that_do_not_fill_the_terrain_are_explained_with_the_sizes_that_do() {
        let p = Path::new("t.tif");
        assert_eq!(TilePlan::new(p, 1009, 2017, 505).unwrap().padding(1009, 2017), None);
        let why = TilePlan::new(p, 1000, 1009, 505).unwrap().padding(1000, 1009).unwrap();
        assert!(why.contains("last column holds 496 and the last row 505 of 505"), "{why}");
        assert!(why.contains("a 1009 x 1009 terrain (--size) fills 2 x 2 tiles exactly, a 505 x 1009 one 1 x 2"), "{why}");
    }

    #[test]
    fn tiles_reassemble_exactly() {
        let d = tmp("tiles");
        let h = sample(70, 45);
        for ext in ["tif", "png", "r16"] {
            let out = d.join(format!("terrain.{ext}"));
            let idx = write_tiles(&out, &h, 16, Some(30.0)).unwrap();
            let back = read_tiles(&idx, 1000).unwrap();
            if ext == "tif" {
                assert_eq!(back, h, "float tiles reassemble to the exact terrain");
            } else {
                // 16-bit tiles share one mapping: they equal the quantised whole terrain
                let (lo, hi) = h.finite_range().unwrap();
                let side = Png16Sidecar::for_range(lo, hi, 16, 16);
                let want = h.map(|v| side.metres(side.quantise(v)));
                assert_eq!(back, want, "{ext} tiles");
            }
            assert!(d.join(format!("terrain_x4_y2.{ext}")).exists(), "engine-style tile names");
        }
    }
}
