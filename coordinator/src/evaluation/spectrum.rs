//! The power spectrum of a terrain, radially averaged, by Welch's method: 128 x 128
//! tiles overlapping by half, each with its best-fit plane removed and a Hann window,
//! their 2-D power spectra (FFT, `rustfft`) averaged. Two figures come from it:
//! - the spectral slope: the least-squares slope of log power against log frequency
//!   for wavelengths of 4 to 64 cells (real terrain falls roughly as f^-2 to f^-3; a
//!   smoothed one falls steeper);
//! - the roughness: the power at wavelengths of 2 to 6 cells over that at 8 to 32
//!   cells (high- against mid-frequency energy), compared as a ratio with the sources'.
//!
//! Both are in cycles per cell, so terrain and sources are compared at the same cell
//! size (exemplars are resampled to the output's).

use rayon::prelude::*;
use ridgeline_terrain::grid::Heightfield;
use rustfft::num_complex::Complex;

/// Tile side of the Welch estimate.
pub const TILE: usize = 128;
const BINS: usize = TILE / 2;

/// Radially averaged power per integer frequency bin (cycles per tile), 1..TILE/2.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Spectrum {
    pub power: Vec<f64>,
    pub tiles: usize,
}

/// The spectrum of `h`, or `None` when it is smaller than a tile or all void.
pub fn spectrum(h: &Heightfield) -> Option<Spectrum> {
    if h.width < TILE || h.height < TILE {
        return None;
    }
    let step = TILE / 2;
    let origins: Vec<(usize, usize)> = (0..=(h.height - TILE) / step)
        .flat_map(|ty| (0..=(h.width - TILE) / step).map(move |tx| (tx * step, ty * step)))
        .collect();
    let fft = rustfft::FftPlanner::<f64>::new().plan_fft_forward(TILE);
    let hann: Vec<f64> = (0..TILE).map(|i| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / TILE as f64).cos()).collect();
    let parts: Vec<Vec<f64>> = origins
        .par_iter()
        .filter_map(|&(x0, y0)| {
            let mut tile = vec![0f64; TILE * TILE];
            for y in 0..TILE {
                for x in 0..TILE {
                    let v = h.get(x0 + x, y0 + y);
                    if !v.is_finite() {
                        return None;
                    }
                    tile[y * TILE + x] = v as f64;
                }
            }
            detrend(&mut tile);
            let mut buf: Vec<Complex<f64>> =
                tile.iter().enumerate().map(|(i, &v)| Complex::new(v * hann[i % TILE] * hann[i / TILE], 0.0)).collect();
            for row in buf.chunks_mut(TILE) {
                fft.process(row);
            }
            let mut col = vec![Complex::new(0.0, 0.0); TILE];
            for x in 0..TILE {
                for y in 0..TILE {
                    col[y] = buf[y * TILE + x];
                }
                fft.process(&mut col);
                for y in 0..TILE {
                    buf[y * TILE + x] = col[y];
                }
            }
            let (mut sum, mut count) = (vec![0f64; BINS + 1], vec![0usize; BINS + 1]);
            for ky in 0..TILE {
                for kx in 0..TILE {
                    let fx = if kx <= TILE / 2 { kx as f64 } else { kx as f64 - TILE as f64 };
                    let fy = if ky <= TILE / 2 { ky as f64 } else { ky as f64 - TILE as f64 };
                    let r = (fx * fx + fy * fy).sqrt().round() as usize;
                    if (1..=BINS).contains(&r) {
                        sum[r] += buf[ky * TILE + kx].norm_sqr();
                        count[r] += 1;
                    }
                }
            }
            Some((0..=BINS).map(|r| if count[r] > 0 { sum[r] / count[r] as f64 } else { 0.0 }).collect())
        })
        .collect();
    if parts.is_empty() {
        return None;
    }
    let mut power = vec![0f64; BINS + 1];
    for p in &parts {
        for (a, b) in power.iter_mut().zip(p) {
            *a += b / parts.len() as f64;
        }
    }
    Some(Spectrum { power, tiles: parts.len() })
}

/// Removes the least-squares plane from a tile.
fn detrend(t: &mut [f64]) {
    let n = TILE as f64;
    let c = (n - 1.0) / 2.0;
    let (mut m, mut sx, mut sy, mut xx) = (0.0, 0.0, 0.0, 0.0);
    for (i, &v) in t.iter().enumerate() {
        let (x, y) = ((i % TILE) as f64 - c, (i / TILE) as f64 - c);
        m += v;
        sx += v * x;
        sy += v * y;
        xx += x * x;
    }
    m /= n * n;
    let (bx, by) = (sx / xx, sy / xx);
    for (i, v) in t.iter_mut().enumerate() {
        let (x, y) = ((i % TILE) as f64 - c, (i / TILE) as f64 - c);
        *v -= m + bx * x + by * y;
    }
}

impl Spectrum {
    /// Bin range of wavelengths from `long` down to `short` cells.
    fn bins(long: f64, short: f64) -> std::ops::RangeInclusive<usize> {
        let lo = (TILE as f64 / long).round().max(1.0) as usize;
        let hi = (TILE as f64 / short).round().min(BINS as f64) as usize;
        lo..=hi
    }

    /// Slope of log10 power against log10 frequency, wavelengths 64 to 4 cells.
    pub fn slope(&self) -> f64 {
        let pts: Vec<(f64, f64)> =
            Self::bins(64.0, 4.0).filter(|&r| self.power[r] > 0.0).map(|r| ((r as f64).log10(), self.power[r].log10())).collect();
        let n = pts.len() as f64;
        let (mx, my) = (pts.iter().map(|p| p.0).sum::<f64>() / n, pts.iter().map(|p| p.1).sum::<f64>() / n);
        let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
        let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
        if sxx > 0.0 {
            sxy / sxx
        } else {
            0.0
        }
    }

    /// Power at wavelengths of 2 to 6 cells over power at 8 to 32 cells.
    pub fn roughness(&self) -> f64 {
        let band = |r: std::ops::RangeInclusive<usize>| r.map(|i| self.power[i]).sum::<f64>();
        let mid = band(Self::bins(32.0, 8.0));
        if mid > 0.0 {
            band(Self::bins(6.0, 2.0)) / mid
        } else {
            0.0
        }
    }

    /// The weighted mean of several spectra.
    pub fn mix(parts: &[(Spectrum, f64)]) -> Option<Spectrum> {
        let total: f64 = parts.iter().map(|p| p.1).sum();
        if parts.is_empty() || total <= 0.0 {
            return None;
        }
        let mut power = vec![0f64; BINS + 1];
        for (s, w) in parts {
            for (a, b) in power.iter_mut().zip(&s.power) {
                *a += b * w / total;
            }
        }
        Some(Spectrum { power, tiles: parts.iter().map(|p| p.0.tiles).sum() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ridgeline_terrain::grid::Grid;

    /// Fractal noise with power falling as f^-beta (sum of octaves of value noise).
    pub(crate) fn fractal(w: usize, beta: f64, seed: u64) -> Heightfield {
        let mut data = vec![0f32; w * w];
        let mut s = seed;
        let mut rnd = move || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((s >> 33) as f64 / (1u64 << 31) as f64) - 0.5
        };
        let mut period = w;
        while period >= 2 {
            let n = w / period + 2;
            let lattice: Vec<f64> = (0..n * n).map(|_| rnd()).collect();
            let amp = (period as f64).powf(beta / 2.0);
            for y in 0..w {
                for x in 0..w {
                    let (fx, fy) = (x as f64 / period as f64, y as f64 / period as f64);
                    let (ix, iy) = (fx as usize, fy as usize);
                    let (tx, ty) = (fx - ix as f64, fy - iy as f64);
                    let (sx, sy) = (tx * tx * (3.0 - 2.0 * tx), ty * ty * (3.0 - 2.0 * ty));
                    let l = |i: usize, j: usize| lattice[j * n + i];
                    let v = (l(ix, iy) * (1.0 - sx) + l(ix + 1, iy) * sx) * (1.0 - sy)
                        + (l(ix, iy + 1) * (1.0 - sx) + l(ix + 1, iy + 1) * sx) * sy;
                    data[y * w + x] += (amp * v) as f32;
                }
            }
            period /= 2;
        }
        Grid::from_vec(w, w, data)
    }

    #[test]
    fn slope_and_roughness_see_smoothing() {
        let rough = fractal(512, 2.2, 7);
        let s = spectrum(&rough).unwrap();
        assert!(s.slope() < -1.0 && s.slope() > -4.5, "slope {}", s.slope());
        // a 3 x 3 box blur removes high frequencies: steeper slope, less roughness
        let blurred = crate::evaluation::box_blur(&rough, 1);
        let b = spectrum(&blurred).unwrap();
        assert!(b.slope() < s.slope() - 0.3, "blur steepens the slope: {} vs {}", b.slope(), s.slope());
        assert!(b.roughness() < 0.5 * s.roughness(), "blur smooths: {} vs {}", b.roughness(), s.roughness());
        // a plane has no spectrum left after detrending; a small terrain has none at all
        let plane: Heightfield = Grid::from_vec(256, 256, (0..256 * 256).map(|i| (i % 256) as f32 * 3.0).collect());
        assert!(spectrum(&plane).unwrap().power.iter().all(|p| *p < 1e-6));
        assert!(spectrum(&Grid::new(100, 100, 0.0)).is_none());
    }
}
