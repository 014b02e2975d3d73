use ridgeline_worker::*;
fn main() {
    let dir = std::path::Path::new("../shared/data/dems");
    let specs = ridgeline_terrain::library::scan_library(dir).unwrap();
    let cell = ridgeline_terrain::library::common_cell_size(&specs);
    let cfg = ShardConfig { patch: 64, out_cell: cell, max_side: 32768, cache: None };
    let items: Vec<(u32, _)> = specs.into_iter().enumerate().map(|(i, s)| (i as u32, s)).collect();
    let t = std::time::Instant::now();
    let shard = InProcessShard::load(&items, &cfg).unwrap();
    println!("load {:?}", t.elapsed());
    for s in shard.source_data() {
        println!("{} {}x{} ridge_nodes {} valley_nodes {} featureless {} min_range {}", s.name, s.heights.width, s.heights.height, s.nodes[0].len(), s.nodes[1].len(), s.featureless.len(), s.min_range);
    }
}
