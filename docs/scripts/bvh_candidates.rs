// The BVH comparison of docs/render.md: a standalone cargo binary with obvhs = "0.4", bvh = "0.13", nalgebra, glam = "0.34".
//! BVH candidates: obvhs 0.4 (CWBVH, PLOC) vs bvh 0.13 (SAH binary, nearest-first iterator).
use std::time::Instant;
type V = [f64; 3];
fn sub(a: V, b: V) -> V { [a[0]-b[0], a[1]-b[1], a[2]-b[2]] }
fn cross(a: V, b: V) -> V { [a[1]*b[2]-a[2]*b[1], a[2]*b[0]-a[0]*b[2], a[0]*b[1]-a[1]*b[0]] }
fn dot(a: V, b: V) -> f64 { a[0]*b[0]+a[1]*b[1]+a[2]*b[2] }
fn norm(a: V) -> V { let l = dot(a,a).sqrt(); [a[0]/l,a[1]/l,a[2]/l] }
fn isect(o: V, d: V, t: &[V;3]) -> f64 {
    let e1 = sub(t[1], t[0]); let e2 = sub(t[2], t[0]);
    let p = cross(d, e2); let det = dot(e1, p);
    if det.abs() < 1e-300 { return f64::INFINITY; }
    let inv = 1.0/det; let s = sub(o, t[0]); let u = dot(s,p)*inv;
    if !(0.0..=1.0).contains(&u) { return f64::INFINITY; }
    let q = cross(s, e1); let v = dot(d,q)*inv;
    if v < 0.0 || u+v > 1.0 { return f64::INFINITY; }
    let tt = dot(e2,q)*inv; if tt > 1e-9 { tt } else { f64::INFINITY }
}
struct R(u64);
impl R { fn f(&mut self) -> f64 { self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407); (self.0>>11) as f64/(1u64<<53) as f64 } }
fn icosphere(level: u32, rng: &mut R) -> Vec<[V;3]> {
    let t = (1.0+5f64.sqrt())/2.0;
    let mut v: Vec<V> = vec![[-1.,t,0.],[1.,t,0.],[-1.,-t,0.],[1.,-t,0.],[0.,-1.,t],[0.,1.,t],[0.,-1.,-t],[0.,1.,-t],[t,0.,-1.],[t,0.,1.],[-t,0.,-1.],[-t,0.,1.]].into_iter().map(norm).collect();
    let mut f: Vec<[usize;3]> = vec![[0,11,5],[0,5,1],[0,1,7],[0,7,10],[0,10,11],[1,5,9],[5,11,4],[11,10,2],[10,7,6],[7,1,8],[3,9,4],[3,4,2],[3,2,6],[3,6,8],[3,8,9],[4,9,5],[2,4,11],[6,2,10],[8,6,7],[9,8,1]];
    for _ in 0..level {
        let mut cache = std::collections::HashMap::new();
        let mut mid = |a: usize, b: usize, v: &mut Vec<V>| *cache.entry((a.min(b), a.max(b))).or_insert_with(|| { v.push(norm([(v[a][0]+v[b][0])/2.,(v[a][1]+v[b][1])/2.,(v[a][2]+v[b][2])/2.])); v.len()-1 });
        let mut nf = vec![];
        for [a,b,c] in f { let ab = mid(a,b,&mut v); let bc = mid(b,c,&mut v); let ca = mid(c,a,&mut v); nf.extend([[a,ab,ca],[b,bc,ab],[c,ca,bc],[ab,bc,ca]]); }
        f = nf;
    }
    for p in v.iter_mut() { let s = 1.0 + 0.05*(rng.f()-0.5); *p = [p[0]*s, p[1]*s, p[2]*s]; }
    f.iter().map(|&[a,b,c]| [v[a],v[b],v[c]]).collect()
}
fn rays(n: usize, rng: &mut R) -> (Vec<(V,V)>, Vec<(V,V)>) {
    let mut inside = vec![]; let mut cam = vec![];
    for _ in 0..n {
        let p = loop { let p = [2.*rng.f()-1., 2.*rng.f()-1., 2.*rng.f()-1.]; if dot(p,p) < 0.8 { break p; } };
        let z = 1.-2.*rng.f(); let r = (1.-z*z).sqrt(); let ph = 6.283185307*rng.f();
        inside.push((p, [r*ph.cos(), r*ph.sin(), z]));
        let (x, y) = (rng.f()*2.4-1.2, rng.f()*2.4-1.2);
        cam.push(([0.,0.,4.], norm([x*0.3, y*0.3, -1.0])));
    }
    (inside, cam)
}
fn main() {
    let mut rng = R(7);
    let tris = icosphere(7, &mut rng); // 327680 tris
    let tris: Vec<[V;3]> = tris.into_iter().step_by(3).collect(); // ~1.1e5 (holes ok for timing)
    println!("{} triangles", tris.len());
    let (inside, cam) = rays(200_000, &mut rng);
    // obvhs
    use obvhs::{BvhBuildParams, cwbvh::builder::build_cwbvh_from_tris, ray::{Ray, RayHit}, triangle::Triangle};
    use glam::Vec3A;
    let v3 = |p: V| Vec3A::new(p[0] as f32, p[1] as f32, p[2] as f32);
    let otris: Vec<Triangle> = tris.iter().map(|t| Triangle { v0: v3(t[0]), v1: v3(t[1]), v2: v3(t[2]) }).collect();
    let t0 = Instant::now();
    let bvh = build_cwbvh_from_tris(&otris, BvhBuildParams::medium_build(), &mut std::time::Duration::default());
    println!("obvhs build {:.3} s", t0.elapsed().as_secs_f64());
    for (name, rs) in [("inside", &inside), ("camera", &cam)] {
        let t0 = Instant::now(); let mut hits = 0usize; let mut sum = 0.0;
        for &(o, d) in rs.iter() {
            let mut best = f64::INFINITY;
            let mut h = RayHit::none();
            bvh.ray_traverse(Ray::new_inf(v3(o), v3(d)), &mut h, |_r, id| { let t = isect(o, d, &tris[bvh.primitive_indices[id] as usize]); if t < best { best = t; } t as f32 });
            if best.is_finite() { hits += 1; sum += best; }
        }
        let dt = t0.elapsed().as_secs_f64();
        println!("obvhs {name}: {:.3e} rays/s (hits {hits}, mean t {:.6})", rs.len() as f64/dt, sum/hits as f64);
    }
    // bvh crate
    use bvh::{aabb::{Aabb, Bounded}, bounding_hierarchy::BHShape, bvh::Bvh};
    use nalgebra::{Point3, Vector3};
    struct S { t: [V;3], node: usize }
    impl Bounded<f32,3> for S { fn aabb(&self) -> Aabb<f32,3> { let mut a = Aabb::empty(); for p in self.t { a.grow_mut(&Point3::new(p[0] as f32, p[1] as f32, p[2] as f32)); } a } }
    impl BHShape<f32,3> for S { fn set_bh_node_index(&mut self, i: usize) { self.node = i; } fn bh_node_index(&self) -> usize { self.node } }
    let mut shapes: Vec<S> = tris.iter().map(|&t| S { t, node: 0 }).collect();
    let t0 = Instant::now();
    let b = Bvh::build(&mut shapes);
    println!("bvh build {:.3} s", t0.elapsed().as_secs_f64());
    for (name, rs) in [("inside", &inside), ("camera", &cam)] {
        let t0 = Instant::now(); let mut hits = 0usize; let mut sum = 0.0;
        for &(o, d) in rs.iter() {
            let ray = bvh::ray::Ray::new(Point3::new(o[0] as f32, o[1] as f32, o[2] as f32), Vector3::new(d[0] as f32, d[1] as f32, d[2] as f32));
            let mut best = f64::INFINITY;
            for s in b.nearest_traverse_iterator(&ray, &shapes) {
                // stop once this shape's box entry is past the best hit
                if let Some((tmin, _)) = ray.intersection_slice_for_aabb(&s.aabb()) { if (tmin as f64) > best { break; } }
                let t = isect(o, d, &s.t); if t < best { best = t; }
            }
            if best.is_finite() { hits += 1; sum += best; }
        }
        let dt = t0.elapsed().as_secs_f64();
        println!("bvh   {name}: {:.3e} rays/s (hits {hits}, mean t {:.6})", rs.len() as f64/dt, sum/hits as f64);
    }
}
