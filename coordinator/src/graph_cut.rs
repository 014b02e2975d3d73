//! Graph-cut seams (Kwatra et al. 2003, as used by Zhou 2007 §V-A and Tasse 2012
//! §4.3.1): over the overlap of the output and a new patch, the minimum cut decides
//! which cells keep the old terrain (source side, A) and which take the new patch
//! (sink side, B). Its value is also the graph-cut cost of round 2 (Crause listing 6.4).
//!
//! Max-flow is Dinic's algorithm, written here because the graphs are small (at most
//! patch² cells), built and solved thousands of times per job, and the crates that
//! exist either pull in a general graph library or lack the residual-graph access we
//! need to read the cut.

use std::collections::VecDeque;

const INF: f64 = 1e30;

/// A flow network with a source (index `n`) and a sink (index `n + 1`).
pub struct FlowGraph {
    n: usize,
    head: Vec<usize>,
    next: Vec<usize>,
    to: Vec<usize>,
    cap: Vec<f64>,
}

const NIL: usize = usize::MAX;

impl FlowGraph {
    /// A network of `n` inner nodes.
    pub fn new(n: usize) -> Self {
        FlowGraph { n, head: vec![NIL; n + 2], next: Vec::new(), to: Vec::new(), cap: Vec::new() }
    }
    pub fn source(&self) -> usize {
        self.n
    }
    pub fn sink(&self) -> usize {
        self.n + 1
    }
    fn arc(&mut self, a: usize, b: usize, c: f64) {
        self.to.push(b);
        self.cap.push(c);
        self.next.push(self.head[a]);
        self.head[a] = self.to.len() - 1;
    }
    /// An undirected edge of capacity `c` between inner nodes.
    pub fn add_edge(&mut self, a: usize, b: usize, c: f64) {
        self.arc(a, b, c);
        self.arc(b, a, c);
    }
    /// A directed arc (with a zero-capacity reverse arc).
    pub fn add_arc(&mut self, a: usize, b: usize, c: f64) {
        self.arc(a, b, c);
        self.arc(b, a, 0.0);
    }
    /// Ties node `a` to the source (`to_source`) or sink with infinite capacity.
    pub fn constrain(&mut self, a: usize, to_source: bool) {
        if to_source {
            self.add_arc(self.source(), a, INF);
        } else {
            self.add_arc(a, self.sink(), INF);
        }
    }

    fn bfs(&self, level: &mut [i32]) -> bool {
        level.fill(-1);
        let s = self.source();
        level[s] = 0;
        let mut q = VecDeque::from([s]);
        while let Some(u) = q.pop_front() {
            let mut e = self.head[u];
            while e != NIL {
                let v = self.to[e];
                if self.cap[e] > 1e-12 && level[v] < 0 {
                    level[v] = level[u] + 1;
                    q.push_back(v);
                }
                e = self.next[e];
            }
        }
        level[self.sink()] >= 0
    }

    fn dfs(&mut self, u: usize, f: f64, level: &[i32], it: &mut [usize]) -> f64 {
        if u == self.sink() {
            return f;
        }
        while it[u] != NIL {
            let e = it[u];
            let v = self.to[e];
            if self.cap[e] > 1e-12 && level[v] == level[u] + 1 {
                let d = self.dfs(v, f.min(self.cap[e]), level, it);
                if d > 0.0 {
                    self.cap[e] -= d;
                    self.cap[e ^ 1] += d;
                    return d;
                }
            }
            it[u] = self.next[e];
        }
        0.0
    }

    /// Runs max-flow; returns the flow value and, per inner node, whether it is on
    /// the source side of the minimum cut.
    pub fn min_cut(mut self) -> (f64, Vec<bool>) {
        let total = self.n + 2;
        let mut level = vec![-1i32; total];
        let mut flow = 0.0;
        while self.bfs(&mut level) {
            let mut it = self.head.clone();
            loop {
                let f = self.dfs(self.source(), INF, &level, &mut it);
                if f <= 0.0 {
                    break;
                }
                flow += f;
                if flow >= INF * 0.5 {
                    break;
                }
            }
        }
        // source side = reachable from the source in the residual graph
        let mut side = vec![false; total];
        let mut q = VecDeque::from([self.source()]);
        side[self.source()] = true;
        while let Some(u) = q.pop_front() {
            let mut e = self.head[u];
            while e != NIL {
                let v = self.to[e];
                if self.cap[e] > 1e-12 && !side[v] {
                    side[v] = true;
                    q.push_back(v);
                }
                e = self.next[e];
            }
        }
        side.truncate(self.n);
        (flow, side)
    }
}

/// Which patch a window cell takes after the cut.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Label {
    /// Keep the output's old value.
    Old,
    /// Take the new patch.
    New,
}

/// Constraint on a window cell before the cut.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Force {
    Free,
    Old,
    New,
}

/// Result of a seam search over one window.
#[derive(Debug, Clone)]
pub struct Seam {
    pub labels: Vec<Label>,
    /// Minimum cut value (0 when there is no overlap).
    pub cost: f64,
    /// Number of overlap edges (to normalise the cost).
    pub edges: usize,
}

/// Finds the optimal seam in a `w x h` window. `old` is NaN where the output is
/// empty (those cells must take the new patch); `new` is the candidate with its mean
/// offset over the overlap already removed; `force` pins cells. The edge weight is
/// the height mismatch of both cells plus the mismatch of the gradient across the
/// edge: the gradient-domain merge hides what a seam's cut through similar slopes
/// leaves, so slopes matter as much as heights.
pub fn find_seam(w: usize, h: usize, old: &[f32], new: &[f32], force: &[Force]) -> Seam {
    let n = w * h;
    let mut node = vec![usize::MAX; n];
    let mut count = 0;
    for i in 0..n {
        if !old[i].is_nan() && force[i] != Force::New {
            node[i] = count;
            count += 1;
        }
    }
    let mut labels: Vec<Label> = (0..n).map(|i| if node[i] == usize::MAX { Label::New } else { Label::Old }).collect();
    if count == 0 {
        return Seam { labels, cost: 0.0, edges: 0 };
    }
    let mut g = FlowGraph::new(count);
    let mut edges = 0usize;
    let weight = |a: usize, b: usize| -> f64 {
        let da = (old[a] - new[a]).abs();
        let db = (old[b] - new[b]).abs();
        let dg = ((old[b] - old[a]) - (new[b] - new[a])).abs();
        (0.5 * (da + db) + dg) as f64 + 1e-6
    };
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if old[i].is_nan() {
                continue;
            }
            for (j, ok) in [(i + 1, x + 1 < w), (i + w, y + 1 < h)] {
                if !ok || old[j].is_nan() {
                    continue;
                }
                edges += 1;
                let c = weight(i, j);
                match (node[i], node[j]) {
                    (usize::MAX, usize::MAX) => {}
                    (usize::MAX, b) => g.add_arc(b, g.sink(), c),
                    (a, usize::MAX) => g.add_arc(a, g.sink(), c),
                    (a, b) => g.add_edge(a, b, c),
                }
            }
            if node[i] != usize::MAX && force[i] == Force::Old {
                g.constrain(node[i], true);
            }
        }
    }
    let (cost, side) = g.min_cut();
    for i in 0..n {
        if node[i] != usize::MAX && !side[node[i]] {
            labels[i] = Label::New;
        }
    }
    Seam { labels, cost, edges }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_minimum_cut_on_a_small_grid() {
        // 3x3 grid, source tied to the left column, sink to the right column.
        // Horizontal capacities: column 0→1 are 5,1,5; column 1→2 are 2,2,2.
        // Vertical capacities 10 everywhere. Min cut: the 1→2 column, value 6.
        let mut g = FlowGraph::new(9);
        let at = |x: usize, y: usize| y * 3 + x;
        let h01 = [5.0, 1.0, 5.0];
        for y in 0..3 {
            g.add_edge(at(0, y), at(1, y), h01[y]);
            g.add_edge(at(1, y), at(2, y), 2.0);
            g.constrain(at(0, y), true);
            g.constrain(at(2, y), false);
        }
        for y in 0..2 {
            for x in 0..3 {
                g.add_edge(at(x, y), at(x, y + 1), 10.0);
            }
        }
        let (flow, side) = g.min_cut();
        assert!((flow - 6.0).abs() < 1e-9, "flow {flow}");
        for y in 0..3 {
            assert!(side[at(0, y)] && side[at(1, y)] && !side[at(2, y)]);
        }
    }

    #[test]
    fn seam_follows_the_region_where_patches_agree() {
        // old and new agree in column 5 only (elsewhere the new patch is the old one
        // plus a checkerboard of ±20); left forced old, right forced new
        let (w, h) = (10, 6);
        let old: Vec<f32> = (0..w * h).map(|i| ((i % w) as f32) * 3.0).collect();
        let new: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if x == 5 {
                    old[i]
                } else {
                    old[i] + if (x + y) % 2 == 0 { 20.0 } else { -20.0 }
                }
            })
            .collect();
        let force: Vec<Force> = (0..w * h)
            .map(|i| match i % w {
                0 => Force::Old,
                9 => Force::New,
                _ => Force::Free,
            })
            .collect();
        let s = find_seam(w, h, &old, &new, &force);
        for y in 0..h {
            for x in 0..w {
                let want = if x <= 5 { Label::Old } else { Label::New };
                // the cut must pass next to column 5 (either side is optimal only there)
                if x <= 4 || x >= 6 {
                    assert_eq!(s.labels[y * w + x], want, "({x},{y})");
                }
            }
        }
    }
}
