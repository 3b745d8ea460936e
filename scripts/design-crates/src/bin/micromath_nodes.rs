// Prints, for every dt (thousandths) where some kappa in 1..=255 gives other ADF flux nodes with
// micromath than with libm, how many (kappa, dt) sets and nodes differ and by how much.
use micromath::F32Ext;
// The ADF flux nodes (fusion-nostd adf/diffusion FluxFn::nodes) with libm's f64 exp and with
// micromath's f32 exp (called through its trait: std's inherent f32::exp would win).
fn nodes(kappa: u32, dt_milli: u32, exp: &dyn Fn(f64) -> f64) -> Vec<i32> {
    let span = (4 * (kappa << 7)).min(1 << 15);
    let shift = (3..=9).find(|&k| 64u32 << k >= span).unwrap_or(9);
    let kq = f64::from(kappa << 7);
    let half_dt = f64::from(dt_milli) / 2000.0;
    let h2 = f64::from(1u32 << (2 * shift));
    (0..=64u32)
        .map(|j| {
            let g = f64::from(j << shift);
            let t = g / kq;
            let e = half_dt * exp(-t * t);
            let curvature = e * (4.0 * t * t * t - 6.0 * t) / kq;
            libm::round(g * e - curvature * h2 / 16.0) as i32
        })
        .collect()
}
fn main() {
    for dt in 1..=250u32 {
        let (mut sets, mut differ, mut nodes_differ, mut max_d) = (0, 0, 0, 0);
        for kappa in 1..=255u32 {
            let a = nodes(kappa, dt, &|x| libm::exp(x));
            let b = nodes(kappa, dt, &|x| f64::from(F32Ext::exp(x as f32)));
            let n = a.iter().zip(&b).filter(|(x, y)| x != y).count();
            let d = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).max().unwrap();
            sets += 1;
            if n > 0 {
                differ += 1;
            }
            nodes_differ += n;
            max_d = max_d.max(d);
            if kappa == 30 && dt == 150 {
                println!("kappa 30 dt 0.15: {n} of 65 nodes differ, max {d} state units");
            }
        }
        if differ > 0 {
            println!(
                "dt {dt}: {differ} of {sets} kappas give other nodes; {nodes_differ} nodes differ in all; max difference {max_d} state units"
            );
        }
    }
}
