// Round 1 of patch matching on the GPU (Crause 2015 §6.2.1–6.3, listing 6.7; Tasse 2012
// §4.2.1 costs): every user patch of a block against every feature candidate of every
// source of the shard, in all 10 variants, then the candidates that can be among the
// k best of each (user patch, source) pair.
//
// CPU twin: worker/src/patch_matching.rs (`approx_cost` is this file's `candidate_cost`
// line by line; `window` is the selection below). Parity test: worker/tests/gpu_parity.rs.
//
// Same bytes on any hardware. Floating-point division, sqrt and fused multiply-adds
// differ between GPUs and CPUs, so the cost this kernel computes (f32, profiles shifted
// by their first sample so the sums do not cancel) is only a filter: for each pair it
// returns every candidate whose cost is within DELTA of the pair's k-th smallest. The
// worker then re-scores those few on the CPU in the ranking form (f64 sums in a fixed
// order, `patch_matching::rank_cost`) and keeps the k best. Any candidate of the true
// k best has a filter cost at most 2ε above the k-th smallest filter cost, where ε is
// the filter's error (about 1e-5 here; the parity test measures it and checks it stays
// below DELTA/10), so the best-set is the ranking form's whatever the device.
//
// One workgroup per (user patch, source) pair: 64 threads stride over the pair's
// candidate-variants and write each cost to `costs`; the selection of the hits is
// window.wgsl's, appended to this file when the worker compiles it.

const PI: f32 = 3.14159265358979323846;
const ALPHA_F: f32 = 5.0;
const ALPHA_A: f32 = 2.0;
const BIG: f32 = 3.0e38; // "no value yet" in min/max

struct Node {
    base: u32,        // flat index of the centre in `heights`
    stride: u32,      // the source's row length
    exit_start: u32,  // into `node_exits`
    exit_count: u32,
}

struct Patch {
    path_start: u32,  // into `paths`
    path_count: u32,
    exit_start: u32,  // into `user_exits`
    exit_count: u32,
}

struct Path {
    sample_start: u32, // into `profile` and, per variant, `offsets`
    sample_count: u32,
}

struct Pair {
    node_start: u32,
    node_count: u32,
    user_patch: u32,
    min_range: f32,
    cost_offset: u32, // into `costs`
    hit_offset: u32,  // into `hits`: count, then cap indices
    _pad0: u32,
    _pad1: u32,
}

struct Params {
    k: u32,
    cap: u32,
    samples: u32,     // total samples of the block: the stride between variants in `offsets`
    delta: f32,
}

@group(0) @binding(0) var<storage, read> heights: array<f32>;
@group(0) @binding(1) var<storage, read> nodes: array<Node>;
@group(0) @binding(2) var<storage, read> node_exits: array<f32>;
@group(0) @binding(3) var<uniform> params: Params;
@group(0) @binding(4) var<storage, read> pairs: array<Pair>;
@group(0) @binding(5) var<storage, read> patches: array<Patch>;
@group(0) @binding(6) var<storage, read> paths: array<Path>;
@group(0) @binding(7) var<storage, read> offsets: array<vec2<i32>>;
@group(0) @binding(8) var<storage, read> profile: array<f32>;
@group(0) @binding(9) var<storage, read> user_exits: array<f32>;
@group(0) @binding(10) var<storage, read_write> costs: array<f32>;
@group(0) @binding(11) var<storage, read_write> hits: array<u32>;

fn map_angle(v: u32, a: f32) -> f32 {
    if v == 8u {
        return PI - a;
    }
    if v == 9u {
        return -a;
    }
    return a + f32(v) * (PI / 4.0);
}

fn angle_diff(a: f32, b: f32) -> f32 {
    var d = abs(a - b);
    if d > 2.0 * PI {
        if d <= 4.0 * PI {
            d = d - 2.0 * PI;
        } else {
            d = d - 2.0 * PI * floor(d / (2.0 * PI));
        }
    }
    if d > PI {
        d = 2.0 * PI - d;
    }
    return d;
}

fn angle_cost(p: Patch, n: Node, v: u32) -> f32 {
    let mismatch = abs(f32(p.exit_count) - f32(n.exit_count)) * 0.5;
    if p.exit_count == 0u || n.exit_count == 0u {
        return mismatch;
    }
    var s = 0.0;
    for (var i = 0u; i < p.exit_count; i++) {
        let u = user_exits[p.exit_start + i];
        var best = BIG;
        for (var j = 0u; j < n.exit_count; j++) {
            best = min(best, angle_diff(u, map_angle(v, node_exits[n.exit_start + j])));
        }
        let d = best / PI;
        s += d * d;
    }
    return s / f32(p.exit_count) + mismatch;
}

fn path_cost(path: Path, n: Node, v: u32, min_range: f32) -> f32 {
    let count = path.sample_count;
    if count == 0u {
        return 0.0;
    }
    let stride = i32(n.stride);
    let first = path.sample_start;
    let o0 = offsets[v * params.samples + first];
    let x0 = heights[u32(i32(n.base) + o0.y * stride + o0.x)];
    // sums in 4 lanes (sample i into lane i % 4), added as (l0 + l1) + (l2 + l3)
    var s = vec4<f32>(0.0);
    var lo = BIG;
    var hi = -BIG;
    for (var i = 0u; i < count; i++) {
        let o = offsets[v * params.samples + first + i];
        let x = heights[u32(i32(n.base) + o.y * stride + o.x)];
        s[i & 3u] += x - x0;
        lo = min(lo, x);
        hi = max(hi, x);
    }
    let m = ((s.x + s.y) + (s.z + s.w)) / f32(count);
    let inv_r = 1.0 / max(hi - lo, min_range);
    var ss = vec4<f32>(0.0);
    for (var i = 0u; i < count; i++) {
        let o = offsets[v * params.samples + first + i];
        let x = heights[u32(i32(n.base) + o.y * stride + o.x)];
        let e = (x - x0 - m) * inv_r - profile[first + i];
        ss[i & 3u] += e * e;
    }
    return sqrt(((ss.x + ss.y) + (ss.z + ss.w)) / f32(count));
}

fn candidate_cost(pair: Pair, i: u32) -> f32 {
    let n = nodes[pair.node_start + i / 10u];
    let v = i % 10u;
    let p = patches[pair.user_patch];
    var sum = 0.0;
    for (var j = 0u; j < p.path_count; j++) {
        sum += path_cost(paths[p.path_start + j], n, v, pair.min_range);
    }
    var cf = 0.0;
    if p.path_count > 0u {
        cf = sum / f32(p.path_count);
    }
    return ALPHA_F * cf + ALPHA_A * angle_cost(p, n, v);
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) t: u32) {
    let pair = pairs[wg.x];
    let total = pair.node_count * 10u;
    var mine = window_empty();
    for (var i = t; i < total; i += 64u) {
        let c = candidate_cost(pair, i);
        costs[pair.cost_offset + i] = c;
        window_push(&mine, c);
    }
    window_select(t, mine, total, pair.cost_offset, pair.hit_offset);
}
