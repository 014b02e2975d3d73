//! `Grid<T>`: a dense row-major 2-D array, the heightfield type of the whole system.
//!
//! Heights are `f32` metres; an empty (not yet synthesised) output pixel is `NaN`.

/// Dense row-major 2-D array.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid<T> {
    pub width: usize,
    pub height: usize,
    pub data: Vec<T>,
}

/// A heightfield in metres; `NaN` marks an empty cell.
pub type Heightfield = Grid<f32>;

impl<T: Copy> Grid<T> {
    pub fn new(width: usize, height: usize, fill: T) -> Self {
        Grid { width, height, data: vec![fill; width * height] }
    }

    pub fn from_vec(width: usize, height: usize, data: Vec<T>) -> Self {
        assert_eq!(data.len(), width * height, "grid data length mismatch");
        Grid { width, height, data }
    }

    #[inline]
    pub fn idx(&self, x: usize, y: usize) -> usize {
        y * self.width + x
    }

    #[inline]
    pub fn get(&self, x: usize, y: usize) -> T {
        self.data[y * self.width + x]
    }

    #[inline]
    pub fn set(&mut self, x: usize, y: usize, v: T) {
        let w = self.width;
        self.data[y * w + x] = v;
    }

    /// Value at signed coordinates, `None` outside the grid.
    #[inline]
    pub fn get_i(&self, x: i64, y: i64) -> Option<T> {
        if x < 0 || y < 0 || x >= self.width as i64 || y >= self.height as i64 {
            None
        } else {
            Some(self.data[y as usize * self.width + x as usize])
        }
    }

    #[inline]
    pub fn contains(&self, x: i64, y: i64) -> bool {
        x >= 0 && y >= 0 && x < self.width as i64 && y < self.height as i64
    }

    pub fn map<U: Copy>(&self, f: impl Fn(T) -> U) -> Grid<U> {
        Grid { width: self.width, height: self.height, data: self.data.iter().map(|&v| f(v)).collect() }
    }
}

/// Catmull-Rom weights of the taps at −1, 0, 1, 2 for a sample at `t` in [0, 1).
pub fn cubic_weights(t: f32) -> [f32; 4] {
    let (t2, t3) = (t * t, t * t * t);
    [0.5 * (-t3 + 2.0 * t2 - t), 0.5 * (3.0 * t3 - 5.0 * t2 + 2.0), 0.5 * (-3.0 * t3 + 4.0 * t2 + t), 0.5 * (t3 - t2)]
}

impl Grid<f32> {
    /// Bilinear sample at continuous coordinates (pixel centres at integers),
    /// clamped to the border.
    pub fn sample_bilinear(&self, x: f32, y: f32) -> f32 {
        let xc = x.clamp(0.0, (self.width - 1) as f32);
        let yc = y.clamp(0.0, (self.height - 1) as f32);
        let x0 = xc.floor() as usize;
        let y0 = yc.floor() as usize;
        let x1 = (x0 + 1).min(self.width - 1);
        let y1 = (y0 + 1).min(self.height - 1);
        let fx = xc - x0 as f32;
        let fy = yc - y0 as f32;
        let a = self.get(x0, y0) * (1.0 - fx) + self.get(x1, y0) * fx;
        let b = self.get(x0, y1) * (1.0 - fx) + self.get(x1, y1) * fx;
        a * (1.0 - fy) + b * fy
    }

    /// Catmull-Rom bicubic sample at continuous coordinates (pixel centres at
    /// integers), taps clamped to the border. Where a rotation or an upsampling has to
    /// fall between cells it keeps more of the fine relief (wavelengths of 3 to 6
    /// cells) than bilinear weights, which average neighbouring cells.
    pub fn sample_bicubic(&self, x: f32, y: f32) -> f32 {
        let xc = x.clamp(0.0, (self.width - 1) as f32);
        let yc = y.clamp(0.0, (self.height - 1) as f32);
        let (x0, y0) = (xc.floor() as i64, yc.floor() as i64);
        let (wx, wy) = (cubic_weights(xc - x0 as f32), cubic_weights(yc - y0 as f32));
        let (mx, my) = (self.width as i64 - 1, self.height as i64 - 1);
        let mut acc = 0f32;
        for (j, wyj) in wy.iter().enumerate() {
            let row = (y0 + j as i64 - 1).clamp(0, my) as usize * self.width;
            let mut r = 0f32;
            for (i, wxi) in wx.iter().enumerate() {
                r += wxi * self.data[row + (x0 + i as i64 - 1).clamp(0, mx) as usize];
            }
            acc += wyj * r;
        }
        acc
    }

    /// Minimum and maximum of the finite values, `None` when there are none.
    pub fn finite_range(&self) -> Option<(f32, f32)> {
        let mut lo = f32::INFINITY;
        let mut hi = f32::NEG_INFINITY;
        for &v in &self.data {
            if v.is_finite() {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        (lo <= hi).then_some((lo, hi))
    }

    /// Number of `NaN` (empty) cells.
    pub fn count_empty(&self) -> usize {
        self.data.iter().filter(|v| v.is_nan()).count()
    }

    /// Resample to a new size by area averaging (downsampling) or bicubic
    /// interpolation (upsampling). Used to bring exemplars to the output cell size.
    pub fn resample(&self, new_w: usize, new_h: usize) -> Heightfield {
        let sx = self.width as f32 / new_w as f32;
        let sy = self.height as f32 / new_h as f32;
        let mut out = Grid::new(new_w, new_h, 0.0f32);
        if sx <= 1.0 && sy <= 1.0 {
            for y in 0..new_h {
                for x in 0..new_w {
                    let v = self.sample_bicubic((x as f32 + 0.5) * sx - 0.5, (y as f32 + 0.5) * sy - 0.5);
                    out.set(x, y, v);
                }
            }
            return out;
        }
        for y in 0..new_h {
            let y0 = (y as f32 * sy).floor() as usize;
            let y1 = (((y + 1) as f32 * sy).ceil() as usize).clamp(y0 + 1, self.height);
            for x in 0..new_w {
                let x0 = (x as f32 * sx).floor() as usize;
                let x1 = (((x + 1) as f32 * sx).ceil() as usize).clamp(x0 + 1, self.width);
                let mut sum = 0.0f64;
                let mut n = 0usize;
                for yy in y0..y1 {
                    for xx in x0..x1 {
                        let v = self.get(xx, yy);
                        if v.is_finite() {
                            sum += v as f64;
                            n += 1;
                        }
                    }
                }
                out.set(x, y, if n > 0 { (sum / n as f64) as f32 } else { f32::NAN });
            }
        }
        out
    }
}

/// Exact squared Euclidean distance transform (Felzenszwalb & Huttenlocher 2012)
/// to the nearest `true` cell of `seeds`. Cells with no seed at all get `f32::INFINITY`.
pub fn distance_transform(seeds: &Grid<bool>) -> Grid<f32> {
    distance_transform_by(seeds.width, seeds.height, |i| seeds.data[i])
}

/// [`distance_transform`] of the cells for which `seed(flat index)` holds, without
/// building a mask first. Exact (Felzenszwalb and Huttenlocher 2012), linear in the
/// cell count: columns are processed 16 at a time, so the strided pass reads whole
/// cache lines, and the lower envelope is computed in f64, so coordinates of large
/// grids (q² beyond f32's 24-bit mantissa) stay exact. Blocks of columns, then rows,
/// are transformed in parallel (each line on its own, so the result does not depend on
/// the thread count); the column blocks go [`COLUMN_BATCH`] at a time, so the copies
/// they are worked in stay a few megabytes whatever the grid.
pub fn distance_transform_by(w: usize, h: usize, seed: impl Fn(usize) -> bool + Sync) -> Grid<f32> {
    use rayon::prelude::*;
    const INF: f32 = 1e20;
    const LANES: usize = 16;
    let mut f: Vec<f32> = (0..w * h).into_par_iter().map(|i| if seed(i) { 0.0 } else { INF }).collect();
    let n = w.max(h);
    let scratch = || (Dt1dScratch::new(n), vec![0f32; n], vec![0f32; n]);
    // columns, LANES at a time: each block copied out, transformed and copied back
    let starts: Vec<usize> = (0..w).step_by(LANES).collect();
    for batch in starts.chunks(COLUMN_BATCH) {
        let f_ref = &f;
        let blocks: Vec<Vec<f32>> = batch
            .par_iter()
            .map_init(scratch, |(sc, d, col), &x0| {
                let lanes = LANES.min(w - x0);
                let mut block = vec![0f32; h * LANES];
                for y in 0..h {
                    block[y * LANES..y * LANES + lanes].copy_from_slice(&f_ref[y * w + x0..y * w + x0 + lanes]);
                }
                for l in 0..lanes {
                    for y in 0..h {
                        col[y] = block[y * LANES + l];
                    }
                    dt1d(&col[..h], &mut d[..h], sc);
                    for y in 0..h {
                        block[y * LANES + l] = d[y];
                    }
                }
                block
            })
            .collect();
        for (&x0, block) in batch.iter().zip(&blocks) {
            let lanes = LANES.min(w - x0);
            for y in 0..h {
                f[y * w + x0..y * w + x0 + lanes].copy_from_slice(&block[y * LANES..y * LANES + lanes]);
            }
        }
    }
    // rows
    f.par_chunks_mut(w.max(1)).for_each_init(scratch, |(sc, d, col), row| {
        col[..w].copy_from_slice(row);
        dt1d(&col[..w], &mut d[..w], sc);
        row.copy_from_slice(&d[..w]);
    });
    f.par_iter_mut().for_each(|v| *v = if *v >= INF * 0.5 { f32::INFINITY } else { v.sqrt() });
    Grid::from_vec(w, h, f)
}

/// Column blocks of [`distance_transform_by`] worked on at once.
const COLUMN_BATCH: usize = 64;

struct Dt1dScratch {
    v: Vec<usize>,
    z: Vec<f64>,
}

impl Dt1dScratch {
    fn new(n: usize) -> Self {
        Dt1dScratch { v: vec![0; n], z: vec![0.0; n + 1] }
    }
}

/// 1-D squared distance transform of `f` (lower envelope of parabolas) into `d`.
fn dt1d(f: &[f32], d: &mut [f32], sc: &mut Dt1dScratch) {
    let n = f.len();
    if n == 0 {
        return;
    }
    let (v, z) = (&mut sc.v, &mut sc.z);
    let fq = |q: usize| f[q] as f64 + (q * q) as f64;
    let mut k = 0usize;
    v[0] = 0;
    z[0] = f64::NEG_INFINITY;
    z[1] = f64::INFINITY;
    for q in 1..n {
        loop {
            let p = v[k];
            let s = (fq(q) - fq(p)) / (2.0 * q as f64 - 2.0 * p as f64);
            if s <= z[k] && k > 0 {
                k -= 1;
                continue;
            }
            if s <= z[k] {
                // k == 0: replace
                v[0] = q;
                z[0] = f64::NEG_INFINITY;
                z[1] = f64::INFINITY;
                break;
            }
            k += 1;
            v[k] = q;
            z[k] = s;
            z[k + 1] = f64::INFINITY;
            break;
        }
    }
    k = 0;
    for (q, dq) in d.iter_mut().enumerate().take(n) {
        while z[k + 1] < q as f64 {
            k += 1;
        }
        let p = v[k];
        let dd = q as f64 - p as f64;
        *dq = (dd * dd + f[p] as f64) as f32;
    }
}

/// Separable box blur of radius `r` applied `passes` times (≈ Gaussian).
pub fn box_blur(g: &Grid<f32>, r: usize, passes: usize) -> Grid<f32> {
    let (w, h) = (g.width, g.height);
    let mut cur = g.data.clone();
    let mut tmp = vec![0f32; w * h];
    for _ in 0..passes {
        for y in 0..h {
            let row = &cur[y * w..(y + 1) * w];
            blur_line(row, &mut tmp[y * w..(y + 1) * w], r);
        }
        let mut colbuf = vec![0f32; h];
        let mut out = vec![0f32; h];
        for x in 0..w {
            for y in 0..h {
                colbuf[y] = tmp[y * w + x];
            }
            blur_line(&colbuf, &mut out, r);
            for y in 0..h {
                cur[y * w + x] = out[y];
            }
        }
    }
    Grid::from_vec(w, h, cur)
}

fn blur_line(src: &[f32], dst: &mut [f32], r: usize) {
    let n = src.len() as i64;
    let r = r as i64;
    for i in 0..n {
        let lo = (i - r).max(0);
        let hi = (i + r).min(n - 1);
        let mut s = 0.0f32;
        for j in lo..=hi {
            s += src[j as usize];
        }
        dst[i as usize] = s / (hi - lo + 1) as f32;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distance_transform_matches_brute_force() {
        let mut seeds = Grid::new(23, 17, false);
        for &(x, y) in &[(3usize, 4usize), (20, 2), (11, 15)] {
            seeds.set(x, y, true);
        }
        let dt = distance_transform(&seeds);
        for y in 0..17 {
            for x in 0..23 {
                let best = [(3usize, 4usize), (20, 2), (11, 15)]
                    .iter()
                    .map(|&(sx, sy)| ((x as f32 - sx as f32).powi(2) + (y as f32 - sy as f32).powi(2)).sqrt())
                    .fold(f32::INFINITY, f32::min);
                assert!((dt.get(x, y) - best).abs() < 1e-3, "({x},{y}) {} vs {best}", dt.get(x, y));
            }
        }
    }

    #[test]
    fn resample_down_preserves_mean_of_constant_and_ramp() {
        let g = Grid::from_vec(6, 3, (0..18).map(|i| (i % 6) as f32).collect());
        let r = g.resample(2, 1);
        assert_eq!(r.data, vec![1.0, 4.0]);
    }
}
