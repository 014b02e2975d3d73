//! PPA steps 3 and 4: polygon breaking by maximum spanning forest (Kruskal), and
//! branch reduction. Also the pixel feature graph every later stage walks.

use super::segments::{Segment, DIRS};
use std::collections::VecDeque;

/// A forest on the pixel lattice: for every cell, a bit mask of the 8 neighbours it
/// is joined to (bit `d` = direction `DIRS[d]`).
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct FeatureGraph {
    pub width: usize,
    pub height: usize,
    mask: Vec<u8>,
}

fn dir_between(w: usize, a: u32, b: u32) -> usize {
    let (ax, ay) = ((a as usize % w) as i64, (a as usize / w) as i64);
    let (bx, by) = ((b as usize % w) as i64, (b as usize / w) as i64);
    let d = (bx - ax, by - ay);
    DIRS.iter().position(|&o| o == d).expect("cells are 8-adjacent")
}

struct UnionFind(Vec<u32>);
impl UnionFind {
    fn find(&mut self, mut x: u32) -> u32 {
        while self.0[x as usize] != x {
            let p = self.0[x as usize];
            self.0[x as usize] = self.0[p as usize];
            x = p;
        }
        x
    }
}

/// Kruskal's algorithm, heaviest segment first: the kept segments form a maximum
/// spanning forest, i.e. every cycle loses its lightest (least important) segment.
/// Where segments are sparse (a sketch: a few stroke centres in a large grid) the
/// union-find covers only the cells they touch, numbered in raster order, so its
/// memory follows the feature cells, not the grid; where they are dense (an exemplar
/// DEM) a direct array is faster. The forest is the same either way.
pub fn maximum_spanning_forest(width: usize, height: usize, mut segs: Vec<Segment>) -> FeatureGraph {
    segs.sort_by(|x, y| y.weight.total_cmp(&x.weight).then(x.a.cmp(&y.a)).then(x.b.cmp(&y.b)));
    let sparse = segs.len() * 16 < width * height;
    let mut cells: Vec<u32> = if sparse { segs.iter().flat_map(|s| [s.a, s.b]).collect() } else { Vec::new() };
    cells.sort_unstable();
    cells.dedup();
    let id = |c: u32| if sparse { cells.binary_search(&c).map(|i| i as u32).unwrap_or(0) } else { c };
    let n = if sparse { cells.len() } else { width * height };
    let mut uf = UnionFind((0..n as u32).collect());
    let mut g = FeatureGraph::empty(width, height);
    for s in segs {
        let (ra, rb) = (uf.find(id(s.a)), uf.find(id(s.b)));
        if ra != rb {
            uf.0[ra as usize] = rb;
            g.add_edge(s.a, s.b);
        }
    }
    g
}

impl FeatureGraph {
    pub fn empty(width: usize, height: usize) -> Self {
        FeatureGraph { width, height, mask: vec![0; width * height] }
    }

    pub fn add_edge(&mut self, a: u32, b: u32) {
        let d = dir_between(self.width, a, b);
        self.mask[a as usize] |= 1 << d;
        self.mask[b as usize] |= 1 << ((d + 4) % 8);
    }

    pub fn remove_edge(&mut self, a: u32, b: u32) {
        let d = dir_between(self.width, a, b);
        self.mask[a as usize] &= !(1 << d);
        self.mask[b as usize] &= !(1 << ((d + 4) % 8));
    }

    #[inline]
    pub fn degree(&self, i: u32) -> u32 {
        self.mask[i as usize].count_ones()
    }

    #[inline]
    pub fn contains(&self, i: u32) -> bool {
        self.mask[i as usize] != 0
    }

    /// Neighbours of cell `i`, in direction order.
    pub fn neighbors(&self, i: u32) -> impl Iterator<Item = u32> + '_ {
        let m = self.mask[i as usize];
        let w = self.width as i64;
        (0..8).filter(move |d| m & (1 << d) != 0).map(move |d| {
            let (dx, dy) = DIRS[d];
            (i as i64 + dy * w + dx) as u32
        })
    }

    /// All cells on the graph, in raster order.
    pub fn pixels(&self) -> impl Iterator<Item = u32> + '_ {
        self.mask.iter().enumerate().filter(|(_, &m)| m != 0).map(|(i, _)| i as u32)
    }

    pub fn xy(&self, i: u32) -> (usize, usize) {
        (i as usize % self.width, i as usize / self.width)
    }

    /// Connected components, each as a list of cells in raster order; components
    /// are ordered by their first cell.
    pub fn components(&self) -> Vec<Vec<u32>> {
        let mut seen = vec![false; self.mask.len()];
        let mut out = Vec::new();
        for p in self.pixels() {
            if seen[p as usize] {
                continue;
            }
            let mut comp = Vec::new();
            let mut q = VecDeque::from([p]);
            seen[p as usize] = true;
            while let Some(c) = q.pop_front() {
                comp.push(c);
                for n in self.neighbors(c) {
                    if !seen[n as usize] {
                        seen[n as usize] = true;
                        q.push_back(n);
                    }
                }
            }
            comp.sort_unstable();
            out.push(comp);
        }
        out
    }

    fn step_len(&self, a: u32, b: u32) -> f32 {
        let d = dir_between(self.width, a, b);
        if d % 2 == 1 {
            std::f32::consts::SQRT_2
        } else {
            1.0
        }
    }

    /// PPA step 4: `passes` times, delete every leaf chain (from a leaf up to, not
    /// including, the first junction) shorter than `min_len`; isolated chains shorter
    /// than `min_len` go too.
    pub fn reduce_branches(&mut self, min_len: f32, passes: usize) {
        for _ in 0..passes {
            let leaves: Vec<u32> = self.pixels().filter(|&p| self.degree(p) == 1).collect();
            let mut doomed: Vec<(u32, u32)> = Vec::new();
            let mut claimed = std::collections::HashSet::new();
            for &leaf in &leaves {
                if claimed.contains(&leaf) {
                    continue;
                }
                let mut chain = Vec::new();
                let mut len = 0.0;
                let (mut prev, mut cur) = (u32::MAX, leaf);
                loop {
                    let next = self.neighbors(cur).find(|&n| n != prev);
                    let Some(n) = next else {
                        break;
                    };
                    chain.push((cur, n));
                    len += self.step_len(cur, n);
                    if self.degree(n) != 2 {
                        if self.degree(n) == 1 {
                            // isolated chain: do not walk it again from its other end
                            claimed.insert(n);
                        }
                        break;
                    }
                    prev = cur;
                    cur = n;
                    if len >= min_len {
                        break;
                    }
                }
                if len < min_len {
                    doomed.extend(chain);
                }
            }
            if doomed.is_empty() {
                break;
            }
            for (a, b) in doomed {
                if self.mask[a as usize] != 0 && self.mask[b as usize] != 0 {
                    self.remove_edge(a, b);
                }
            }
        }
    }

    /// Sparse serialisation: (cell, mask) pairs.
    pub fn to_sparse(&self) -> Vec<(u32, u8)> {
        self.pixels().map(|p| (p, self.mask[p as usize])).collect()
    }

    /// Inverse of [`to_sparse`](Self::to_sparse); `None` if a pair is out of range
    /// or the masks are not symmetric.
    pub fn from_sparse(width: usize, height: usize, pairs: &[(u32, u8)]) -> Option<Self> {
        let mut g = FeatureGraph::empty(width, height);
        for &(p, m) in pairs {
            *g.mask.get_mut(p as usize)? = m;
        }
        for p in 0..g.mask.len() as u32 {
            for (d, off) in DIRS.iter().enumerate() {
                if g.mask[p as usize] & (1 << d) != 0 {
                    let (x, y) = g.xy(p);
                    let (nx, ny) = (x as i64 + off.0, y as i64 + off.1);
                    if nx < 0 || ny < 0 || nx >= width as i64 || ny >= height as i64 {
                        return None;
                    }
                    let n = ny as usize * width + nx as usize;
                    if g.mask[n] & (1 << ((d + 4) % 8)) == 0 {
                        return None;
                    }
                }
            }
        }
        Some(g)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kruskal_breaks_a_square_at_its_lightest_side() {
        // 2x2 square of cells 0,1,2,3 (w=2): edges 0-1 (10), 1-3 (9), 3-2 (8), 2-0 (1)
        let segs = vec![
            Segment { a: 0, b: 1, weight: 10.0 },
            Segment { a: 1, b: 3, weight: 9.0 },
            Segment { a: 2, b: 3, weight: 8.0 },
            Segment { a: 0, b: 2, weight: 1.0 },
        ];
        let g = maximum_spanning_forest(2, 2, segs);
        assert_eq!(g.degree(0), 1);
        assert_eq!(g.degree(2), 1);
        assert!(!g.neighbors(0).any(|n| n == 2));
    }

    #[test]
    fn short_spurs_are_removed_long_ones_kept() {
        // a horizontal line of 30 cells with a 3-cell spur and a 15-cell spur
        let w = 40;
        let mut g = FeatureGraph::empty(w, 40);
        let at = |x: usize, y: usize| (y * w + x) as u32;
        for x in 0..29 {
            g.add_edge(at(x, 5), at(x + 1, 5));
        }
        for y in 5..8 {
            g.add_edge(at(10, y), at(10, y + 1));
        }
        for y in 5..20 {
            g.add_edge(at(20, y), at(20, y + 1));
        }
        g.reduce_branches(6.0, 2);
        assert!(!g.contains(at(10, 8)), "short spur removed");
        assert!(g.contains(at(20, 20)), "long spur kept");
        assert!(g.contains(at(0, 5)) && g.contains(at(29, 5)), "main line kept");
        let round = FeatureGraph::from_sparse(w, 40, &g.to_sparse()).unwrap();
        assert_eq!(round, g);
    }
}
