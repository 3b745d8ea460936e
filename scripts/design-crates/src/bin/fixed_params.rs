// What the core's public parameters would become as binary fixed-point values (the `fixed`
// crate's types) instead of the decimal-scaled integers they are (thousandths, tenths, parts per
// million): which published values survive, and how many of ADF's flux nodes change over every
// (kappa, dt) the core accepts when dt goes through the narrowest type that holds 0.25 with 16
// fractional bits (U0F16) and through U8F8 (the width of the other Q8 fields).
use fixed::types::{U0F16, U8F8, U16F16};

// The ADF flux nodes (fusion-nostd methods/adf/diffusion FluxFn::nodes) for a time step `dt`.
fn nodes(kappa: u32, dt: f64) -> Vec<i32> {
    let span = (4 * (kappa << 7)).min(1 << 15);
    let shift = (3..=9).find(|&k| 64u32 << k >= span).unwrap_or(9);
    let kq = f64::from(kappa << 7);
    let half_dt = dt / 2.0;
    let h2 = f64::from(1u32 << (2 * shift));
    (0..=64u32)
        .map(|j| {
            let g = f64::from(j << shift);
            let t = g / kq;
            let e = half_dt * libm::exp(-t * t);
            let curvature = e * (4.0 * t * t * t - 6.0 * t) / kq;
            libm::round(g * e - curvature * h2 / 16.0) as i32
        })
        .collect()
}

fn main() {
    // The published decimal parameters the core takes exactly today.
    let published = [
        ("ADF dt = 0.15 (dt_milli 150)", 0.15),
        ("IFEVIP MaxRatio = 0.001 (top_ppm 1000)", 0.001),
        ("scene k_sigma = 6.0 (k_sigma_tenths 60)", 6.0),
        ("scene block k = 5.0 (block_k_sigma_tenths 50)", 5.0),
        ("ADF dt = 0.1 (dt_milli 100)", 0.1),
    ];
    for (name, v) in published {
        let q16 = U16F16::from_num(v).to_num::<f64>();
        let q8 = U8F8::from_num(v).to_num::<f64>();
        println!(
            "{name}: U16F16 {q16:.9} ({}), U8F8 {q8:.9} ({})",
            if q16 == v { "exact" } else { "not exact" },
            if q8 == v { "exact" } else { "not exact" }
        );
    }
    for (ty, to_binary) in [
        ("U0F16", &(|dt: f64| U0F16::from_num(dt).to_num::<f64>()) as &dyn Fn(f64) -> f64),
        ("U8F8", &|dt: f64| U8F8::from_num(dt).to_num::<f64>()),
    ] {
        let (mut sets, mut differ, mut nodes_differ, mut max_d) = (0u32, 0u32, 0usize, 0i32);
        let mut published_nodes = 0;
        for dt_milli in 1..=250u32 {
            let dt = f64::from(dt_milli) / 1000.0;
            for kappa in 1..=255u32 {
                let a = nodes(kappa, dt);
                let b = nodes(kappa, to_binary(dt));
                let n = a.iter().zip(&b).filter(|(x, y)| x != y).count();
                sets += 1;
                differ += u32::from(n > 0);
                nodes_differ += n;
                max_d = max_d.max(a.iter().zip(&b).map(|(x, y)| (x - y).abs()).max().unwrap_or(0));
                if kappa == 30 && dt_milli == 150 {
                    published_nodes = n;
                }
            }
        }
        println!(
            "dt through {ty}: {differ} of {sets} (kappa, dt) sets get other flux nodes ({nodes_differ} nodes, up to {max_d} state units); kappa 30, dt 0.15: {published_nodes} of 65 nodes differ"
        );
    }
}
