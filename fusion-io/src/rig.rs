//! A VIS/TIR camera pair's calibration, as OpenCV's calibration tools write it.
//!
//! The file is OpenCV's `FileStorage` form, YAML (`%YAML:1.0` or `%YAML 1.2`, matrices tagged
//! `!!opencv-matrix`) or JSON (matrices as objects with `"type_id": "opencv-matrix"`), with
//! `stereoCalibrate`'s convention: camera 1 = VIS, camera 2 = TIR, `X_tir = R·X_vis + T`,
//! metres. Keys:
//!
//! | key | what |
//! |---|---|
//! | `camera_matrix_vis`, `camera_matrix_tir` | 3 × 3 `[fx 0 cx; 0 fy cy; 0 0 1]`, pixels (no skew) |
//! | `dist_coeffs_vis`, `dist_coeffs_tir` | `k1, k2, p1, p2[, k3]` (4 or 5 values, any shape) |
//! | `image_size_vis`, `image_size_tir` | width, height (a matrix or a plain list) |
//! | `R` | 3 × 3 rotation, VIS to TIR |
//! | `T` | 3 translation, metres |
//!
//! ```
//! let dir = tempfile::tempdir()?;
//! let path = dir.path().join("rig.json");
//! std::fs::write(&path, fusion_io::rig::example_json())?;
//! let rig = fusion_io::rig::read(&path)?;
//! assert_eq!((rig.vis.width, rig.tir.width), (1024, 512));
//! # Ok::<(), anyhow::Error>(())
//! ```
//!
//! A file that is not such a calibration is refused in one line naming the file and what is
//! wrong (a missing key, a matrix of another shape, a rotation that is not one, a skewed camera
//! matrix, an image size outside 1..=16384, a non-finite number).

use anyhow::{Context, Result, anyhow, bail, ensure};
use fusion_nostd::registration::{Camera, Rig};
use std::path::Path;
use yaml_rust2::{Yaml, YamlLoader};

/// One value of the file: its numbers, row-major, and its shape.
struct Matrix {
    rows: usize,
    cols: usize,
    data: Vec<f64>,
}

fn number_yaml(v: &Yaml) -> Option<f64> {
    match v {
        Yaml::Real(_) => v.as_f64(),
        Yaml::Integer(i) => Some(*i as f64),
        // FileStorage writes non-finite values as `.Nan`/`.Inf`: refused below as non-finite.
        Yaml::String(s) => s.parse().ok(),
        _ => None,
    }
}

fn matrix_yaml(v: &Yaml) -> Option<Matrix> {
    match v {
        Yaml::Array(a) => {
            Some(Matrix { rows: 1, cols: a.len(), data: a.iter().map(number_yaml).collect::<Option<_>>()? })
        }
        Yaml::Hash(_) => {
            let data: Vec<f64> = v["data"].as_vec()?.iter().map(number_yaml).collect::<Option<_>>()?;
            let rows = usize::try_from(v["rows"].as_i64()?).ok()?;
            let cols = usize::try_from(v["cols"].as_i64()?).ok()?;
            Some(Matrix { rows, cols, data })
        }
        _ => None,
    }
}

fn matrix_json(v: &serde_json::Value) -> Option<Matrix> {
    let numbers = |a: &Vec<serde_json::Value>| a.iter().map(|x| x.as_f64()).collect::<Option<Vec<f64>>>();
    match v {
        serde_json::Value::Array(a) => Some(Matrix { rows: 1, cols: a.len(), data: numbers(a)? }),
        serde_json::Value::Object(o) => {
            let data = numbers(o.get("data")?.as_array()?)?;
            let rows = usize::try_from(o.get("rows")?.as_u64()?).ok()?;
            let cols = usize::try_from(o.get("cols")?.as_u64()?).ok()?;
            Some(Matrix { rows, cols, data })
        }
        _ => None,
    }
}

/// A parsed file: its matrix under a key.
type Lookup = Box<dyn Fn(&str) -> Result<Matrix>>;

/// The file's matrices by key.
fn parse(text: &str) -> Result<Lookup> {
    let trimmed = text.trim_start();
    if trimmed.starts_with('{') {
        let doc: serde_json::Value =
            serde_json::from_str(text).map_err(|e| anyhow!("not valid JSON: {e}"))?;
        return Ok(Box::new(move |key| {
            let v = doc.get(key).ok_or_else(|| anyhow!("no `{key}`"))?;
            matrix_json(v).ok_or_else(|| anyhow!("`{key}` is not a matrix or a list of numbers"))
        }));
    }
    // OpenCV 3/4 begin with `%YAML:1.0`, which YAML parsers do not take; 5 writes `%YAML 1.2`.
    let body: String = if trimmed.starts_with("%YAML:") {
        trimmed.split_once('\n').map_or("", |(_, rest)| rest).to_string()
    } else {
        text.to_string()
    };
    let docs = YamlLoader::load_from_str(&body).map_err(|e| anyhow!("not valid YAML: {e}"))?;
    let doc = docs.into_iter().next().ok_or_else(|| anyhow!("an empty file"))?;
    Ok(Box::new(move |key| {
        let v = &doc[key];
        if v.is_badvalue() {
            bail!("no `{key}`");
        }
        matrix_yaml(v).ok_or_else(|| anyhow!("`{key}` is not a matrix or a list of numbers"))
    }))
}

fn camera(get: &dyn Fn(&str) -> Result<Matrix>, band: &str) -> Result<Camera> {
    let k = get(&format!("camera_matrix_{band}"))?;
    ensure!(k.rows == 3 && k.cols == 3 && k.data.len() == 9, "`camera_matrix_{band}` is not 3 x 3");
    let d = get(&format!("dist_coeffs_{band}"))?;
    ensure!(
        d.data.len() == 4 || d.data.len() == 5,
        "`dist_coeffs_{band}` has {} values: k1, k2, p1, p2[, k3] expected",
        d.data.len()
    );
    let s = get(&format!("image_size_{band}"))?;
    ensure!(s.data.len() == 2, "`image_size_{band}` is not width, height");
    let all = k.data.iter().chain(&d.data).chain(&s.data);
    ensure!(all.clone().all(|v| v.is_finite()), "`{band}` camera has a non-finite number");
    let [fx, skew, cx, zero0, fy, cy, zero1, zero2, one] = k.data[..] else { unreachable!() };
    ensure!(fx > 0.0 && fy > 0.0, "`camera_matrix_{band}`: focal lengths must be positive");
    ensure!(skew == 0.0, "`camera_matrix_{band}`: a skewed camera matrix is not supported");
    ensure!(
        zero0 == 0.0 && zero1 == 0.0 && zero2 == 0.0 && one == 1.0,
        "`camera_matrix_{band}` is not [fx 0 cx; 0 fy cy; 0 0 1]"
    );
    let size = |v: f64, what: &str| -> Result<usize> {
        ensure!(
            v.fract() == 0.0 && (1.0..=fusion_nostd::MAX_DIMENSION as f64).contains(&v),
            "`image_size_{band}`: {what} {v} is not 1..={}",
            fusion_nostd::MAX_DIMENSION
        );
        Ok(v as usize)
    };
    let mut dist = [0.0f32; 5];
    for (o, &v) in dist.iter_mut().zip(&d.data) {
        *o = v as f32;
    }
    Ok(Camera {
        fx: fx as f32,
        fy: fy as f32,
        cx: cx as f32,
        cy: cy as f32,
        dist,
        width: size(s.data[0], "width")?,
        height: size(s.data[1], "height")?,
    })
}

/// Reads a rig from OpenCV's calibration text (YAML or JSON).
pub fn from_text(text: &str) -> Result<Rig> {
    let get = parse(text)?;
    let vis = camera(&*get, "vis")?;
    let tir = camera(&*get, "tir")?;
    let r = get("R")?;
    ensure!(r.rows * r.cols == 9 && r.data.len() == 9, "`R` is not 3 x 3");
    let t = get("T")?;
    ensure!(t.data.len() == 3, "`T` does not have 3 values");
    ensure!(r.data.iter().chain(&t.data).all(|v| v.is_finite()), "`R` or `T` has a non-finite number");
    // A rotation: RᵀR = I and det R = +1, to the precision calibration files carry.
    let m = |i: usize, j: usize| r.data[3 * i + j];
    for i in 0..3 {
        for j in 0..3 {
            let dot: f64 = (0..3).map(|k| m(k, i) * m(k, j)).sum();
            let want = if i == j { 1.0 } else { 0.0 };
            ensure!((dot - want).abs() < 1e-6, "`R` is not a rotation (its columns are not orthonormal)");
        }
    }
    let det = m(0, 0) * (m(1, 1) * m(2, 2) - m(1, 2) * m(2, 1))
        - m(0, 1) * (m(1, 0) * m(2, 2) - m(1, 2) * m(2, 0))
        + m(0, 2) * (m(1, 0) * m(2, 1) - m(1, 1) * m(2, 0));
    ensure!(det > 0.0, "`R` is a reflection, not a rotation");
    let mut rf = [[0.0f32; 3]; 3];
    for (i, row) in rf.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = m(i, j) as f32;
        }
    }
    let rig = Rig { vis, tir, r: rf, t: [t.data[0] as f32, t.data[1] as f32, t.data[2] as f32] };
    rig.check().map_err(|e| anyhow!("{e}"))?;
    Ok(rig)
}

/// Reads a rig file; one-line errors name the file.
pub fn read(path: &Path) -> Result<Rig> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read the rig {}", path.display()))?;
    from_text(&text).with_context(|| format!("the rig {}", path.display()))
}

/// An example rig file (JSON): a 1024² visible camera of 30° and a 512² thermal camera of 35°
/// 0.2 m to its right — the project's default offset rig (`fusion register --help`).
pub fn example_json() -> &'static str {
    include_str!("rig_example.json")
}

/// The rig as OpenCV's `FileStorage` JSON (what [`read`] takes back; the values are the rig's
/// `f32`s written with every digit they hold).
pub fn to_json(rig: &Rig) -> String {
    let matrix = |rows: usize, cols: usize, dt: &str, data: &[f64]| {
        let data: Vec<String> = data
            .iter()
            .map(|v| if dt == "i" { format!("{}", *v as i64) } else { format!("{v:?}") })
            .collect();
        format!(
            "{{ \"type_id\": \"opencv-matrix\", \"rows\": {rows}, \"cols\": {cols}, \"dt\": \"{dt}\", \"data\": [ {} ] }}",
            data.join(", ")
        )
    };
    let f = |v: f32| f64::from(v);
    let mut keys = Vec::new();
    for (band, c) in [("vis", &rig.vis), ("tir", &rig.tir)] {
        let k = [f(c.fx), 0.0, f(c.cx), 0.0, f(c.fy), f(c.cy), 0.0, 0.0, 1.0];
        keys.push((format!("camera_matrix_{band}"), matrix(3, 3, "d", &k)));
        let d: Vec<f64> = c.dist.iter().map(|&v| f(v)).collect();
        keys.push((format!("dist_coeffs_{band}"), matrix(1, 5, "d", &d)));
        keys.push((format!("image_size_{band}"), matrix(1, 2, "i", &[c.width as f64, c.height as f64])));
    }
    let r: Vec<f64> = rig.r.iter().flatten().map(|&v| f(v)).collect();
    keys.push(("R".to_string(), matrix(3, 3, "d", &r)));
    let t: Vec<f64> = rig.t.iter().map(|&v| f(v)).collect();
    keys.push(("T".to_string(), matrix(3, 1, "d", &t)));
    let body: Vec<String> = keys.iter().map(|(k, v)| format!("    \"{k}\": {v}")).collect();
    format!("{{\n{}\n}}\n", body.join(",\n"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_round_trips() {
        let rig = from_text(example_json()).unwrap();
        let again = from_text(&to_json(&rig)).unwrap();
        assert_eq!(rig, again);
        // Sizes are written as integers, as OpenCV writes them.
        assert!(to_json(&rig).contains("\"data\": [ 1024, 1024 ]"));
    }
}
