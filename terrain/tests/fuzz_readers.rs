//! Property test over every reader with arbitrary bytes: valid files of each format,
//! mutated (bit flips, truncation, splices, random lengths) and pure noise, for a
//! bounded time per reader. Each input must give `Ok` or a typed error naming the file;
//! any panic fails the test. `RIDGELINE_FUZZ_SECONDS` sets the time per reader
//! (default 1.5 s).

use ridgeline_terrain::dem_formats::{encode_ascii_grid, encode_hgt, parse_ascii_grid, parse_hgt, parse_tiff};
use ridgeline_terrain::grid::Grid;
use ridgeline_terrain::io::{decode_dem_png, decode_sketch};
use ridgeline_terrain::outputs::encode_tiff_f32_with_cell;
use std::path::Path;
use std::time::{Duration, Instant};

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

fn mutate(rng: &mut Rng, seed: &[u8]) -> Vec<u8> {
    let mut v = seed.to_vec();
    match rng.below(6) {
        0 => {
            for _ in 0..1 + rng.below(8) {
                if !v.is_empty() {
                    let i = rng.below(v.len());
                    v[i] ^= 1 << rng.below(8);
                }
            }
        }
        1 => v.truncate(rng.below(v.len() + 1)),
        2 => {
            let i = rng.below(v.len() + 1);
            let extra: Vec<u8> = (0..rng.below(64)).map(|_| rng.next() as u8).collect();
            v.splice(i..i, extra);
        }
        3 => {
            for _ in 0..rng.below(16) {
                if !v.is_empty() {
                    let i = rng.below(v.len());
                    v[i] = [0u8, 0xff, b'0', b' ', b'\n', b'-', 0x7f][rng.below(7)];
                }
            }
        }
        4 => v = (0..rng.below(512)).map(|_| rng.next() as u8).collect(),
        _ => {
            // overwrite a 4-byte field (sizes, offsets) with an extreme value
            if v.len() >= 4 {
                let i = rng.below(v.len() - 3);
                let x: u32 = [0, 1, 0xffff_ffff, 0x7fff_ffff, 65536][rng.below(5)];
                v[i..i + 4].copy_from_slice(&x.to_le_bytes());
            }
        }
    }
    v
}

fn budget() -> Duration {
    let s: f64 = std::env::var("RIDGELINE_FUZZ_SECONDS").ok().and_then(|v| v.parse().ok()).unwrap_or(1.5);
    Duration::from_secs_f64(s)
}

fn fuzz(name: &str, seed: Vec<u8>, read: impl Fn(&Path, &[u8]) -> Result<(), String>) {
    let path = Path::new(name);
    assert!(read(path, &seed).is_ok(), "{name}: the unmutated seed must parse");
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15 ^ name.len() as u64);
    let t = Instant::now();
    let mut n = 0u64;
    while t.elapsed() < budget() {
        let input = mutate(&mut rng, &seed);
        if let Err(e) = read(path, &input) {
            assert!(e.contains(name), "{name}: error does not name the file: {e}");
        }
        n += 1;
    }
    eprintln!("{name}: {n} inputs, no panic");
}

fn terrain(w: usize, h: usize) -> Grid<f32> {
    Grid::from_vec(w, h, (0..w * h).map(|i| ((i * 31) % 997) as f32 * 1.5).collect())
}

const LIMIT: u32 = 4096;

#[test]
fn png_dem_reader_survives_arbitrary_bytes() {
    let g = terrain(24, 17);
    let img =
        image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(24, 17, g.data.iter().map(|&v| v as u16).collect()).unwrap();
    let mut buf = std::io::Cursor::new(Vec::new());
    img.write_to(&mut buf, image::ImageFormat::Png).unwrap();
    fuzz("dem.png", buf.into_inner(), |p, b| decode_dem_png(p, b, LIMIT).map(|_| ()).map_err(|e| e.to_string()));
}

#[test]
fn sketch_reader_survives_arbitrary_bytes() {
    let img = image::GrayImage::from_fn(20, 20, |x, y| image::Luma([if x == y { 255 } else { 128 }]));
    let mut buf = std::io::Cursor::new(Vec::new());
    img.write_to(&mut buf, image::ImageFormat::Png).unwrap();
    fuzz("sketch.png", buf.into_inner(), |p, b| decode_sketch(p, b, LIMIT).map(|_| ()).map_err(|e| e.to_string()));
}

#[test]
fn tiff_reader_survives_arbitrary_bytes() {
    let seed = encode_tiff_f32_with_cell(&terrain(19, 11), Some(30.0)).unwrap();
    fuzz("dem.tif", seed, |p, b| parse_tiff(p, b, LIMIT).map(|_| ()).map_err(|e| e.to_string()));
}

#[test]
fn hgt_reader_survives_arbitrary_bytes() {
    fuzz("N00E000.hgt", encode_hgt(&terrain(40, 40)), |p, b| parse_hgt(p, b, LIMIT).map(|_| ()).map_err(|e| e.to_string()));
}

#[test]
fn ascii_grid_reader_survives_arbitrary_bytes() {
    let seed = encode_ascii_grid(&terrain(9, 7), 30.0).into_bytes();
    fuzz("dem.asc", seed, |p, b| parse_ascii_grid(p, b, LIMIT).map(|_| ()).map_err(|e| e.to_string()));
}

#[test]
fn manifest_reader_survives_arbitrary_bytes() {
    let dir = std::env::temp_dir().join(format!("rl-fuzz-manifest-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("a.hgt"), [0u8; 8]).unwrap();
    for (ext, seed) in [
        ("toml", "[[exemplar]]\nfile = \"a.hgt\"\ncell_size_m = 30\nunit = \"feet\"\nnodata = -9999\n".to_string()),
        ("json", r#"{"exemplar": [{"file": "a.hgt", "cell_size_m": 30, "unit": "metres"}]}"#.to_string()),
    ] {
        let name = format!("lib.{ext}");
        let path = dir.join(&name);
        fuzz(&name, seed.into_bytes(), |_, b| {
            std::fs::write(&path, b).unwrap();
            ridgeline_terrain::library::read_manifest(&path).map(|_| ()).map_err(|e| e.to_string())
        });
    }
}
