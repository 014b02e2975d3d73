use ridgeline::pipeline::*;
use ridgeline::quality::adherence;
use ridgeline_terrain::FeatureKind;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let sketch = std::path::PathBuf::from(&args[1]);
    let cfg = SynthConfig { cache_dir: Some("out/cache".into()), ..Default::default() };
    let out = run_job(&sketch, std::path::Path::new("../shared/data/dems"), &cfg).unwrap();
    for s in &out.report.stages { println!("{:>20} {:.3}", s.stage, s.seconds); }
    for k in FeatureKind::BOTH {
        let a = adherence(&out.terrain, out.sketch.graph(k), k, 16.0, 4, 8);
        let b = adherence(&out.features_only.map(|v| if v.is_nan() {0.0} else {v}), out.sketch.graph(k), k, 16.0, 4, 8);
        println!("{:?} adherence {}/{} = {:.3} (features only {:.3})", k, a.matching, a.sampled, a.fraction(), b.fraction());
    }
    let cell = out.report.cell_size_m.unwrap_or(90.0);
    ridgeline_terrain::io::write_rgb_png(std::path::Path::new("out/final.png"), &ridgeline_terrain::io::hillshade(&out.terrain, cell)).unwrap();
    ridgeline_terrain::io::write_rgb_png(std::path::Path::new("out/features.png"), &ridgeline_terrain::io::hillshade(&out.features_only, cell)).unwrap();
    // provenance seams image: mark cells whose provenance differs from right/down neighbour
    let c = &out.canvas;
    let mut img = ridgeline_terrain::io::hillshade(&out.terrain, cell);
    for y in 0..c.provenance.height-1 { for x in 0..c.provenance.width-1 {
        let p = c.provenance.get(x,y);
        if p != c.provenance.get(x+1,y) || p != c.provenance.get(x,y+1) { img.put_pixel(x as u32, y as u32, image::Rgb([255,0,0])); }
    }}
    for u in &out.user_patches { for dy in 0..3 { for dx in 0..3 { let (x,y)=(u.cx+dx,u.cy+dy); if x<img.width() as usize && y<img.height() as usize { img.put_pixel(x as u32,y as u32, if u.kind==FeatureKind::Ridge {image::Rgb([0,255,0])} else {image::Rgb([0,0,255])}); } } } }
    ridgeline_terrain::io::write_rgb_png(std::path::Path::new("out/seams.png"), &img).unwrap();
}
