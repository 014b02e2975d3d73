// The selection both scoring kernels end with (appended to round1.wgsl and fill.wgsl
// when the worker compiles them; it uses their `params.k`, `params.cap`,
// `params.delta`, `costs` and `hits`). CPU twin: `patch_matching::window`.
//
// One workgroup owns one query (a user patch x source pair, or a fill target). Each of
// its 64 threads has kept the K smallest costs it computed (`window_push`); thread 0
// merges the 64 sorted lists up to the k-th smallest; the threshold is that plus
// DELTA (everything when there are fewer than k); every thread then appends the
// indices of its costs under the threshold to the query's hit list (in any order: the
// worker sorts after re-scoring) and thread 0 writes the count, which may exceed the
// list's capacity: the worker then scores that query on the CPU.

const WINDOW_KMAX: u32 = 16u;
const WINDOW_THREADS: u32 = 64u;
const WINDOW_BIG: f32 = 3.0e38;

var<workgroup> window_lists: array<f32, 1024>; // WINDOW_THREADS * WINDOW_KMAX
var<workgroup> window_threshold: f32;
var<workgroup> window_count: atomic<u32>;

fn window_empty() -> array<f32, 16> {
    var mine: array<f32, 16>;
    for (var j = 0u; j < WINDOW_KMAX; j++) {
        mine[j] = WINDOW_BIG;
    }
    return mine;
}

// Inserts `c` into the thread's ascending list of its k smallest.
fn window_push(mine: ptr<function, array<f32, 16>>, c: f32) {
    if c < (*mine)[params.k - 1u] {
        var j = params.k - 1u;
        while j > 0u && (*mine)[j - 1u] > c {
            (*mine)[j] = (*mine)[j - 1u];
            j -= 1u;
        }
        (*mine)[j] = c;
    }
}

// Called by every thread of the workgroup, in uniform control flow.
fn window_select(t: u32, mine: array<f32, 16>, total: u32, cost_offset: u32, hit_offset: u32) {
    if t == 0u {
        atomicStore(&window_count, 0u);
    }
    for (var j = 0u; j < WINDOW_KMAX; j++) {
        window_lists[t * WINDOW_KMAX + j] = mine[j];
    }
    workgroupBarrier();
    if t == 0u {
        var heads: array<u32, 64>;
        for (var j = 0u; j < WINDOW_THREADS; j++) {
            heads[j] = 0u;
        }
        var kth = WINDOW_BIG;
        for (var r = 0u; r < params.k; r++) {
            var best = WINDOW_BIG;
            var at = 0u;
            for (var j = 0u; j < WINDOW_THREADS; j++) {
                if heads[j] < params.k {
                    let c = window_lists[j * WINDOW_KMAX + heads[j]];
                    if c < best {
                        best = c;
                        at = j;
                    }
                }
            }
            heads[at] += 1u;
            kth = best;
        }
        if kth >= WINDOW_BIG {
            window_threshold = WINDOW_BIG;
        } else {
            window_threshold = kth + params.delta;
        }
    }
    workgroupBarrier();
    let th = window_threshold;
    for (var i = t; i < total; i += WINDOW_THREADS) {
        if costs[cost_offset + i] <= th {
            let slot = atomicAdd(&window_count, 1u);
            if slot < params.cap {
                hits[hit_offset + 1u + slot] = i;
            }
        }
    }
    workgroupBarrier();
    if t == 0u {
        hits[hit_offset] = atomicLoad(&window_count);
    }
}
