use s2g_geom::{Setup, load_mesh, normalize_unit_cube};
use s2g_toolpath::{PlanOptions, Tool, slice_setup};
fn main() {
    let path = std::env::args().nth(1).unwrap();
    let h: f64 = std::env::args().nth(2).unwrap().parse().unwrap();
    let m = load_mesh(&path).unwrap();
    let (m, _) = normalize_unit_cube(&m).unwrap();
    println!("tris {}", m.triangles().len());
    let opts = PlanOptions { layer_height: h, stock_margin: 0.02, ..Default::default() };
    let t = std::time::Instant::now();
    let s = slice_setup::<std::convert::Infallible>(&m, &Setup::top(), &Tool::flat(0.001), &opts).unwrap();
    let el = t.elapsed();
    let v: Vec<usize> = s.keepouts.iter().map(|k| k.vertex_count()).collect();
    let k = &s.keepouts[s.keepouts.len()-1];
    let loops = k.loops();
    let mut areas: Vec<f64> = loops.iter().map(|l| l.signed_area()).collect();
    areas.sort_by(|a,b| a.abs().total_cmp(&b.abs()));
    println!("last: shapes {} loops {} neg {} smallest {:?}", k.shape_count(), loops.len(), areas.iter().filter(|a| **a<0.0).count(), &areas[..areas.len().min(8)]);
    let big: Vec<usize> = loops.iter().map(|l| l.points.len()).filter(|&n| n > 100).collect();
    println!("big loops {:?}", big);
    println!("levels {} time {:?} mean verts {} max {}", v.len(), el, v.iter().sum::<usize>() / v.len().max(1), v.iter().max().unwrap());
}
#[allow(dead_code)]
fn dummy() {}
