// Hole-fill candidate scoring on the GPU (Crause 2015 §7.3, Tasse 2012 §4.2.2): a batch
// of fill targets (the known cells of each target window) against every featureless
// candidate of the shard in its 6 exact variants; for each target, the candidates that
// can be among its k best.
//
// CPU twin: worker/src/fill_scoring.rs (`approx_cost` is this file's `candidate_cost`
// line by line). Parity test: worker/tests/gpu_parity.rs.
//
// Same bytes on any hardware, as in round1.wgsl: the f32 cost computed here (overlap
// as a two-pass RMS of the height difference with its mean removed, shifted by the
// first difference so the sums do not cancel; plus the noise, relief, coherence,
// repetition and seed terms) is only a filter. The kernel returns every candidate within DELTA
// of the target's k-th smallest filter cost, and the worker re-scores those on the CPU
// in the ranking form (`fill_scoring::exact_cost`: f64 sums in a fixed lane order).
//
// One workgroup per target: 64 threads stride over candidate x variant and write each
// cost to `costs`; the selection of the hits is window.wgsl's.

const ALPHA_O: f32 = 1.0;
const ALPHA_N: f32 = 0.1;
const BETA_C: f32 = 0.3;
const ALPHA_R: f32 = 0.2;
const REPEAT_PENALTY: f32 = 2.0;

struct Cand {
    source: u32,
    x: u32,
    y: u32,
    _pad0: u32,
    noise: vec4<f32>,  // the 3 noise levels, then the relief (ln, about its plane)
}

struct Target {
    sample_start: u32, // into `sample_val` and, per variant, `sample_idx`
    sample_count: u32,
    relief: f32,
    has_noise: u32,    // bit 0: the noise levels are known; bit 1: the relief is
    noise: vec4<f32>,  // as Cand's
    coh_start: u32,    // into `coherence`
    coh_count: u32,
    avoid_start: u32,  // into `avoid`
    avoid_count: u32,
    cost_offset: u32,  // into `costs`
    hit_offset: u32,   // into `hits`: count, then cap indices
    _pad0: u32,
    _pad1: u32,
}

struct Coherence {
    source: u32,
    share: f32,
}

struct Params {
    k: u32,
    cap: u32,
    samples: u32,     // total samples of the batch: the stride between variants in `sample_idx`
    delta: f32,
    cands: u32,
    pixels: u32,      // patch * patch
    half: u32,        // patch / 2: the repetition radius
    _pad0: u32,
}

@group(0) @binding(0) var<storage, read> pixels: array<f32>;
@group(0) @binding(1) var<storage, read> cands: array<Cand>;
@group(0) @binding(2) var<storage, read> jitter: array<f32>;
@group(0) @binding(3) var<uniform> params: Params;
@group(0) @binding(4) var<storage, read> targets: array<Target>;
@group(0) @binding(5) var<storage, read> sample_idx: array<u32>;
@group(0) @binding(6) var<storage, read> sample_val: array<f32>;
@group(0) @binding(7) var<storage, read> coherence: array<Coherence>;
@group(0) @binding(8) var<storage, read> avoid: array<vec4<u32>>;
@group(0) @binding(9) var<storage, read_write> costs: array<f32>;
@group(0) @binding(10) var<storage, read_write> hits: array<u32>;

fn overlap(t: Target, c: u32, v: u32) -> f32 {
    let n = t.sample_count;
    if n == 0u {
        return 0.0;
    }
    let base = c * params.pixels;
    let first = v * params.samples + t.sample_start;
    let d0 = pixels[base + sample_idx[first]] - sample_val[t.sample_start];
    var s = 0.0;
    for (var i = 0u; i < n; i++) {
        s += (pixels[base + sample_idx[first + i]] - sample_val[t.sample_start + i]) - d0;
    }
    let m = s / f32(n);
    var ss = 0.0;
    for (var i = 0u; i < n; i++) {
        let e = (pixels[base + sample_idx[first + i]] - sample_val[t.sample_start + i]) - d0 - m;
        ss += e * e;
    }
    return sqrt(ss / f32(n));
}

fn candidate_cost(t: Target, i: u32) -> f32 {
    let c = i / 6u;
    let v = i % 6u;
    let cand = cands[c];
    let co = overlap(t, c, v) / t.relief;
    var cn = 0.0;
    if (t.has_noise & 1u) != 0u {
        let d = t.noise - cand.noise;
        cn = sqrt(d.x * d.x + d.y * d.y + d.z * d.z) / 3.0;
    }
    var cr = 0.0;
    if (t.has_noise & 2u) != 0u {
        cr = ALPHA_R * abs(t.noise.w - cand.noise.w);
    }
    var coh = 0.0;
    for (var j = 0u; j < t.coh_count; j++) {
        let e = coherence[t.coh_start + j];
        if e.source == cand.source {
            coh = e.share;
            break;
        }
    }
    var rep = 0.0;
    for (var j = 0u; j < t.avoid_count; j++) {
        let a = avoid[t.avoid_start + j];
        let dx = abs(i32(a.y) - i32(cand.x));
        let dy = abs(i32(a.z) - i32(cand.y));
        if a.x == cand.source && dx < i32(params.half) && dy < i32(params.half) {
            rep = REPEAT_PENALTY;
            break;
        }
    }
    return ALPHA_O * co + ALPHA_N * cn + cr - BETA_C * coh + rep + jitter[i];
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) t: u32) {
    let tg = targets[wg.x];
    let total = params.cands * 6u;
    var mine = window_empty();
    for (var i = t; i < total; i += 64u) {
        let c = candidate_cost(tg, i);
        costs[tg.cost_offset + i] = c;
        window_push(&mine, c);
    }
    window_select(t, mine, total, tg.cost_offset, tg.hit_offset);
}
