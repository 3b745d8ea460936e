//! `vistir`: the VIS/TIR fusion core, its metrics and its renderer from Python.
//!
//! Every function takes and returns numpy arrays (`uint8`, `uint16`; grey `(H, W)`, colour
//! `(H, W, 3)`) and runs with the GIL released. Inputs whose rows are contiguous (any row
//! stride) are read in place; the output is written in place into the array returned. The
//! names of methods, variants, policies, filters and suites are the `fusion` CLI's, and so are
//! the results, bit for bit (`tests/test_vistir.py` checks it against the CLI).

use anyhow::{Context, bail};
use clap::ValueEnum;
use fusion_engine::methods::FilterArg;
use fusion_engine::methods::{AgcArg, MethodArg, RescaleArg, SkipArg, VariantArg, method_for};
use fusion_io::{Channels, Gray};
use fusion_metrics::table::Suite;
use fusion_nostd::pipeline::{FuseConfig, FuseReport, SkipPolicy};
use fusion_nostd::scene::Rect;
use fusion_nostd::sequence::{Pass, Restart, Sequence as CoreSequence, SequenceParams};
use fusion_nostd::{AgcParams, FrameMut, FrameRef};
use numpy::ndarray::ArrayView2;
use numpy::{
    IntoPyArray, PyArray2, PyArrayMethods, PyReadonlyArray2, PyReadonlyArray3, PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyOSError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// A Python exception for a host error: `OSError` when a file operation failed, `ValueError`
/// for everything else (the core's refusals, bad names), with the whole message chain.
fn py_err(e: anyhow::Error) -> PyErr {
    let message = fusion_io::console::one_line(&e);
    if e.chain().any(|c| c.downcast_ref::<std::io::Error>().is_some()) {
        PyOSError::new_err(message)
    } else {
        PyValueError::new_err(message)
    }
}

/// A name the CLI knows for `what`, or a `ValueError` listing the names.
fn named<T: ValueEnum>(what: &str, name: &str) -> PyResult<T> {
    T::from_str(name, false).map_err(|_| {
        let names: Vec<String> = T::value_variants()
            .iter()
            .filter_map(|v| v.to_possible_value().map(|p| p.get_name().to_string()))
            .collect();
        PyValueError::new_err(format!("{what} {name:?} is not one of {}", names.join(", ")))
    })
}

/// A 2-D array's pixels as the core reads them: in place when each row is contiguous, else a
/// contiguous copy.
struct Plane<'a, T: Clone> {
    data: std::borrow::Cow<'a, [T]>,
    width: usize,
    height: usize,
    stride: usize,
}

impl<'a, T: Copy> Plane<'a, T> {
    fn of(view: ArrayView2<'a, T>) -> Self {
        let (height, width) = view.dim();
        let strides = view.strides();
        if height > 0 && width > 0 && strides[1] == 1 && strides[0] >= width as isize {
            let stride = strides[0] as usize;
            let len = (height - 1) * stride + width;
            // SAFETY: numpy's buffer holds `height` rows `stride` elements apart, each with
            // `width` contiguous elements from `as_ptr()`: `len` elements in all, alive and not
            // written while the read-only borrow (`PyReadonlyArray`) lasts.
            let data = unsafe { std::slice::from_raw_parts(view.as_ptr(), len) };
            return Plane { data: data.into(), width, height, stride };
        }
        let data: Vec<T> = view.iter().copied().collect();
        Plane { data: data.into(), width, height, stride: width }
    }

    fn view(&self) -> anyhow::Result<FrameRef<'_, T>> {
        Ok(FrameRef::with_stride(&self.data, self.width, self.height, self.stride)?)
    }

    fn to_gray(&self) -> anyhow::Result<Gray<T>>
    where
        T: Default,
    {
        let v = self.view()?;
        Ok(Gray { width: self.width, height: self.height, data: v.rows().flatten().copied().collect() })
    }
}

/// The planes of a colour `(H, W, 3)` array as the host's [`Channels`] (a copy: colour is
/// converted anyway).
fn channels_of(rgb: &PyReadonlyArray3<'_, u8>) -> anyhow::Result<Channels> {
    let a = rgb.as_array();
    let (h, w, c) = a.dim();
    if c != 3 {
        bail!("a colour image is (H, W, 3); this one is (H, W, {c})");
    }
    let planes = (0..3).map(|k| a.index_axis(numpy::ndarray::Axis(2), k).iter().copied().collect()).collect();
    Ok(Channels { width: w, height: h, planes })
}

/// An image argument: grey 8-bit, grey 16-bit or colour 8-bit.
enum Image<'py> {
    Gray8(PyReadonlyArray2<'py, u8>),
    Gray16(PyReadonlyArray2<'py, u16>),
    Rgb8(PyReadonlyArray3<'py, u8>),
}

impl<'py> Image<'py> {
    fn of(what: &str, obj: &Bound<'py, PyAny>) -> PyResult<Self> {
        if let Ok(a) = obj.extract::<PyReadonlyArray2<'py, u8>>() {
            return Ok(Image::Gray8(a));
        }
        if let Ok(a) = obj.extract::<PyReadonlyArray2<'py, u16>>() {
            return Ok(Image::Gray16(a));
        }
        if let Ok(a) = obj.extract::<PyReadonlyArray3<'py, u8>>()
            && a.shape()[2] == 3
        {
            return Ok(Image::Rgb8(a));
        }
        let described = match obj.extract::<Bound<'py, numpy::PyUntypedArray>>() {
            Ok(a) => format!("a {}-D array of {}", a.ndim(), a.dtype()),
            Err(_) => format!("a {}", obj.get_type().name().map(|n| n.to_string()).unwrap_or_default()),
        };
        Err(PyTypeError::new_err(format!(
            "{what}: need a numpy uint8 (H, W) or (H, W, 3), or uint16 (H, W) array; got {described}"
        )))
    }
}

/// The core configuration the CLI builds from these names.
fn pipeline(method: &str, variant: &str, rescale: &str, skip: &str) -> PyResult<FuseConfig> {
    Ok(FuseConfig {
        method: method_for(named::<MethodArg>("method", method)?, named::<VariantArg>("variant", variant)?),
        rescale: named::<RescaleArg>("rescale", rescale)?.into(),
        skip: named::<SkipArg>("skip", skip)?.into(),
        ..FuseConfig::default()
    })
}

/// The AGC parameters of the CLI's `--agc` and `--plateau` for a frame of `pixels`.
fn agc_params(agc: &str, plateau: Option<u32>, pixels: usize) -> PyResult<AgcParams> {
    let mode = named::<AgcArg>("agc", agc)?;
    match (mode, plateau) {
        (AgcArg::Linear, Some(_)) => Err(PyValueError::new_err("plateau= is for agc=\"plateau\"")),
        (_, Some(0)) => Err(PyValueError::new_err("plateau must be at least 1 pixel per bin")),
        _ => Ok(fusion_engine::agc::params(mode, plateau, 0, pixels)),
    }
}

/// The fused grey frame and what the core reported.
/// In a sequence (`seq`), the frame takes the weights the sequence carries (the core's
/// `fuse_in_sequence` / `fuse_strips_in_sequence`).
fn fuse_gray(
    vis: &Plane<'_, u8>,
    tir: &Plane<'_, u8>,
    pipeline: &FuseConfig,
    strips: Option<usize>,
    out: &mut [u8],
    grid: (usize, usize),
    seq: Option<&mut CoreSequence>,
) -> anyhow::Result<FuseReport> {
    let out = FrameMut::new(out, grid.0, grid.1)?;
    if let Some(rows) = strips {
        let mut scratch = fusion_engine::strips::HostStripScratch::default();
        let mut sv = scratch.view_mut();
        let (report, _) = match seq {
            None => {
                fusion_nostd::strips::fuse_strips(vis.view()?, tir.view()?, out, &mut sv, pipeline, rows)?
            }
            Some(seq) => fusion_nostd::strips::fuse_strips_in_sequence(
                vis.view()?,
                tir.view()?,
                out,
                &mut sv,
                pipeline,
                rows,
                seq,
            )?,
        };
        return Ok(report);
    }
    let pixels = pipeline.scratch_pixels((vis.width, vis.height), (tir.width, tir.height))?;
    SCRATCH.with_borrow_mut(|kept| {
        // The work memory of the largest frame so far, kept for the thread's next call (the
        // output never depends on what the scratch held: the core's contract).
        let scratch = match kept {
            Some(s) if s.pixels() >= pixels => s,
            _ => kept.insert(fusion_engine::CoreScratch::new(pixels)),
        };
        let mut sv = scratch.view_mut();
        Ok(match seq {
            None => fusion_nostd::fuse(vis.view()?, tir.view()?, out, &mut sv, pipeline)?,
            Some(seq) => {
                fusion_nostd::fuse_in_sequence(vis.view()?, tir.view()?, out, &mut sv, pipeline, seq)?
            }
        })
    })
}

thread_local! {
    /// Each thread's work memory, kept between calls: allocating and zeroing 13 bytes per
    /// pixel on every call cost more than the fusion itself on small frames (IFEVIP's scratch
    /// covers at least its 512² normalisation grid). BENCHMARKS.md, "From C and Python".
    static SCRATCH: std::cell::RefCell<Option<fusion_engine::CoreScratch>> = const { std::cell::RefCell::new(None) };
}

/// The report as a dict (`report=True`).
fn report_dict<'py>(py: Python<'py>, r: &FuseReport) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("grid", r.grid)?;
    d.set_item("rescaled", r.rescaled)?;
    d.set_item("guards", r.guards.to_string())?;
    d.set_item("guard_bits", r.guards.0)?;
    let s = &r.skip;
    d.set_item("skip_taken", s.taken.0)?;
    d.set_item("skip_declined", s.declined.map(|d| format!("{d:?}")))?;
    d.set_item("illumination", s.illumination.map(|i| format!("{i:?}")))?;
    d.set_item("window", (s.computed.x0, s.computed.y0, s.computed.x1, s.computed.y1))?;
    d.set_item("background", s.background)?;
    Ok(d)
}

/// Fuses a visible and a thermal frame: the same bytes as `fusion fuse`.
///
/// vis: uint8 (H, W) grey or (H, W, 3) RGB (the luminance is fused, the colour kept: an
///   (H, W, 3) result). tir: uint8 (h, w), or uint16 (h, w) thermal counts mapped to 8 bits
///   by the core AGC first (agc="linear" 1-99.9 %, or "plateau" equalisation with `plateau`
///   pixels per bin). method: "adf", "tsifsd", "ifevip", "adaptive"; variant: "flight" or
///   "classic"; rescale: "tir-up" (bicubic onto the VIS grid), "vis-down" (area onto the TIR
///   grid), "none"; skip: "none", "roi", "all" (scene skipping). window=(x0, y0, x1, y1) skips
///   with the caller's box of the fusion grid instead (columns x0..x1, rows y0..y1, end
///   excluded; e.g. a navigation filter's predicted target box; `fusion fuse --window`).
///   strips=N fuses in the 512 KiB strip working set, at most N rows a strip (the same bytes).
///   report=True returns (image, dict) with the grid, guards and what skipping did.
///
/// Rows that are contiguous in memory are read in place (any row stride); the GIL is released
/// while the core runs. Raises TypeError for an array of another dtype or shape, ValueError
/// with the core's message for sizes or names it refuses.
#[pyfunction]
#[pyo3(signature = (vis, tir, method="tsifsd", variant="flight", rescale="tir-up", skip="none", *, agc="linear", plateau=None, strips=None, window=None, report=false))]
#[allow(clippy::too_many_arguments)]
fn fuse<'py>(
    py: Python<'py>,
    vis: &Bound<'py, PyAny>,
    tir: &Bound<'py, PyAny>,
    method: &str,
    variant: &str,
    rescale: &str,
    skip: &str,
    agc: &str,
    plateau: Option<u32>,
    strips: Option<usize>,
    window: Option<(usize, usize, usize, usize)>,
    report: bool,
) -> PyResult<Py<PyAny>> {
    let pipeline = configured(method, variant, rescale, skip, strips, window)?;
    let (image, r) = fuse_frame(py, vis, tir, &pipeline, agc, plateau, strips, None)?;
    if report {
        let d = report_dict(py, &r)?;
        return Ok((image, d).into_pyobject(py)?.into_any().unbind());
    }
    Ok(image)
}

/// The pipeline of `fuse`'s names, with the caller's window and the strips checked.
fn configured(
    method: &str,
    variant: &str,
    rescale: &str,
    skip: &str,
    strips: Option<usize>,
    window: Option<(usize, usize, usize, usize)>,
) -> PyResult<FuseConfig> {
    let mut pipeline = pipeline(method, variant, rescale, skip)?;
    if let Some((x0, y0, x1, y1)) = window {
        if skip != "none" {
            return Err(PyValueError::new_err("give window= or skip=, not both"));
        }
        if x1 <= x0 || y1 <= y0 {
            return Err(PyValueError::new_err(
                "window: the box is empty (x1 must exceed x0 and y1 exceed y0)",
            ));
        }
        pipeline.skip = SkipPolicy::Window(Rect { x0, y0, x1, y1 });
    }
    if strips == Some(0) {
        return Err(PyValueError::new_err("strips is the most rows per strip: at least 1 (or None)"));
    }
    if strips.is_some() && pipeline.skip != SkipPolicy::None {
        return Err(PyValueError::new_err(
            "strips run without scene skipping: give skip=\"none\" and no window",
        ));
    }
    Ok(pipeline)
}

/// One frame pair as `fuse` takes it (grey or colour VIS, 8-bit or 16-bit TIR), fused with
/// `pipeline` (in `seq` when given): the image (colour when VIS was) and the core's report.
#[allow(clippy::too_many_arguments)]
fn fuse_frame<'py>(
    py: Python<'py>,
    vis: &Bound<'py, PyAny>,
    tir: &Bound<'py, PyAny>,
    pipeline: &FuseConfig,
    agc: &str,
    plateau: Option<u32>,
    strips: Option<usize>,
    seq: Option<&mut CoreSequence>,
) -> PyResult<(Py<PyAny>, FuseReport)> {
    let (vis_in, tir_in) = (Image::of("vis", vis)?, Image::of("tir", tir)?);
    // The visible frame: grey as given, colour as its luminance with the chroma kept.
    let (vis_gray, chroma) = match &vis_in {
        Image::Gray8(a) => (Plane::of(a.as_array()), None),
        Image::Gray16(_) => {
            return Err(PyValueError::new_err(
                "vis is 16-bit; give an 8-bit one (the AGC is for the thermal band)",
            ));
        }
        Image::Rgb8(a) => {
            let [y, cb, cr] = fusion_engine::color::rgb_to_ycbcr(&channels_of(a).map_err(py_err)?);
            (Plane { width: y.width, height: y.height, stride: y.width, data: y.data.into() }, Some([cb, cr]))
        }
    };
    // The thermal frame: 8-bit as given, 16-bit counts through the core AGC, colour as grey.
    let tir_gray: Plane<'_, u8> = match &tir_in {
        Image::Gray8(a) => Plane::of(a.as_array()),
        Image::Gray16(a) => {
            let counts = Plane::of(a.as_array());
            let params = agc_params(agc, plateau, counts.width * counts.height)?;
            let mut mapped = Gray::<u8>::new(counts.width, counts.height);
            py.detach(|| -> anyhow::Result<()> {
                let mut state = fusion_engine::agc::fresh();
                fusion_nostd::agc_frame(&mut state, counts.view()?, mapped.view_mut()?, &params)?;
                Ok(())
            })
            .context("tir: AGC")
            .map_err(py_err)?;
            Plane {
                width: mapped.width,
                height: mapped.height,
                stride: mapped.width,
                data: mapped.data.into(),
            }
        }
        Image::Rgb8(a) => {
            let g = channels_of(a).map_err(py_err)?.to_gray();
            Plane { width: g.width, height: g.height, stride: g.width, data: g.data.into() }
        }
    };
    let grid = fusion_nostd::pipeline::fusion_grid(
        (vis_gray.width, vis_gray.height),
        (tir_gray.width, tir_gray.height),
        pipeline.rescale,
    )
    .map_err(|e| py_err(e.into()))?;
    let fused = PyArray2::<u8>::zeros(py, [grid.1, grid.0], false);
    // SAFETY: the array was just created here and no Python code can see it yet.
    let out = unsafe { fused.as_slice_mut() }.map_err(|e| PyValueError::new_err(e.to_string()))?;
    let r =
        py.detach(|| fuse_gray(&vis_gray, &tir_gray, pipeline, strips, out, grid, seq)).map_err(py_err)?;
    let image: Py<PyAny> = match chroma {
        None => fused.into_any().unbind(),
        Some([cb, cr]) => {
            let y = Gray { width: grid.0, height: grid.1, data: fused.readonly().as_slice()?.to_vec() };
            let rgb = py.detach(|| fusion_engine::color::fused_in_colour(&y, &cb, &cr)).map_err(py_err)?;
            rgb.interleaved().into_pyarray(py).reshape([grid.1, grid.0, 3])?.into_any().unbind()
        }
    };
    Ok((image, r))
}

/// A sequence of frame pairs fused in order with the core's sequence mode: ADF's KL weights
/// carried from each frame to the next (one pass over the strips), the first frame and a frame
/// after a change of illumination class, covariance size (more than `size_change_percent` per
/// cent) or parameters with its own weights; the other methods per frame. The same bytes as
/// `fusion fuse --sequence-mode` on a folder of the frames in name order.
///
/// Sequence(method="adf", variant="flight", rescale="tir-up", skip="none", *, agc="linear",
/// plateau=None, strips=None, window=None, size_change_percent=150, window_frames=5); with
/// skip="roi" or "all" the target boxes of the last `window_frames` frames are joined to each
/// frame's own; `.fuse(vis, tir,
/// report=False)` as `vistir.fuse` (report=True adds the step: "pass" — "carried", "own",
/// "per-frame" — "restart", "p_ir_used", "p_ir_own"); `.reset()` forgets the carried weights.
#[pyclass(module = "vistir")]
struct Sequence {
    pipeline: FuseConfig,
    agc: String,
    plateau: Option<u32>,
    strips: Option<usize>,
    seq: CoreSequence,
}

#[pymethods]
impl Sequence {
    #[new]
    #[pyo3(signature = (method="adf", variant="flight", rescale="tir-up", skip="none", *, agc="linear", plateau=None, strips=None, window=None, size_change_percent=150, window_frames=5))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        method: &str,
        variant: &str,
        rescale: &str,
        skip: &str,
        agc: &str,
        plateau: Option<u32>,
        strips: Option<usize>,
        window: Option<(usize, usize, usize, usize)>,
        size_change_percent: u16,
        window_frames: u8,
    ) -> PyResult<Self> {
        let pipeline = configured(method, variant, rescale, skip, strips, window)?;
        named::<AgcArg>("agc", agc)?;
        let params = SequenceParams { size_change_percent, window_frames };
        params.validate().map_err(|e| py_err(e.into()))?;
        Ok(Self { pipeline, agc: agc.to_string(), plateau, strips, seq: CoreSequence::new(params) })
    }

    /// Fuses the next frame pair of the sequence.
    #[pyo3(signature = (vis, tir, report=false))]
    fn fuse<'py>(
        &mut self,
        py: Python<'py>,
        vis: &Bound<'py, PyAny>,
        tir: &Bound<'py, PyAny>,
        report: bool,
    ) -> PyResult<Py<PyAny>> {
        let (image, r) = fuse_frame(
            py,
            vis,
            tir,
            &self.pipeline,
            &self.agc,
            self.plateau,
            self.strips,
            Some(&mut self.seq),
        )?;
        if !report {
            return Ok(image);
        }
        let d = report_dict(py, &r)?;
        if let Some(step) = self.seq.last_step() {
            let (pass, restart) = match step.pass {
                Pass::Carried => ("carried", None),
                Pass::Own(r) => (
                    "own",
                    Some(match r {
                        Restart::First => "first",
                        Restart::Illumination => "illumination",
                        Restart::Size => "size",
                        Restart::Method => "method",
                    }),
                ),
                Pass::PerFrame => ("per-frame", None),
            };
            let q30 = f64::from(1u32 << 30);
            d.set_item("pass", pass)?;
            d.set_item("restart", restart)?;
            d.set_item("p_ir_used", step.p_ir_used_q30 as f64 / q30)?;
            d.set_item("p_ir_own", step.p_ir_own_q30 as f64 / q30)?;
        }
        Ok((image, d).into_pyobject(py)?.into_any().unbind())
    }

    /// Forgets the carried weights: the next frame takes its own.
    fn reset(&mut self) {
        self.seq.reset();
    }
}

/// Rescales a grey image with the core's rescalers (`fusion rescale`): filter "cubic" (Keys,
/// a = -0.75, cv2.INTER_CUBIC) or "area" (cv2.INTER_AREA); bit-exact with OpenCV at factor 2.
/// img: uint8 or uint16 (H, W); returns the same dtype, (height, width).
#[pyfunction]
#[pyo3(signature = (img, width, height, filter="cubic"))]
fn rescale<'py>(
    py: Python<'py>,
    img: &Bound<'py, PyAny>,
    width: usize,
    height: usize,
    filter: &str,
) -> PyResult<Py<PyAny>> {
    let filter: fusion_nostd::Filter = named::<FilterArg>("filter", filter)?.into();
    fn run<'py, T: fusion_nostd::Sample + numpy::Element + Default + Send + Sync>(
        py: Python<'py>,
        src: &PyReadonlyArray2<'py, T>,
        w: usize,
        h: usize,
        filter: fusion_nostd::Filter,
    ) -> PyResult<Py<PyAny>> {
        let plane = Plane::of(src.as_array());
        let out = PyArray2::<T>::zeros(py, [h, w], false);
        // SAFETY: created here, not visible to Python yet.
        let slice = unsafe { out.as_slice_mut() }.map_err(|e| PyValueError::new_err(e.to_string()))?;
        py.detach(|| -> anyhow::Result<()> {
            fusion_nostd::rescale(plane.view()?, FrameMut::new(slice, w, h)?, filter)?;
            Ok(())
        })
        .map_err(py_err)?;
        Ok(out.into_any().unbind())
    }
    match Image::of("img", img)? {
        Image::Gray8(a) => run(py, &a, width, height, filter),
        Image::Gray16(a) => run(py, &a, width, height, filter),
        Image::Rgb8(_) => Err(PyTypeError::new_err("img: rescale takes a grey (H, W) uint8 or uint16 array")),
    }
}

/// An 8-bit image argument as the host's [`Channels`] (grey or colour).
fn channels_arg(what: &str, obj: &Bound<'_, PyAny>) -> PyResult<Channels> {
    match Image::of(what, obj)? {
        Image::Gray8(a) => {
            let g = Plane::of(a.as_array()).to_gray().map_err(py_err)?;
            Ok(Channels::from_gray(g))
        }
        Image::Rgb8(a) => channels_of(&a).map_err(py_err),
        Image::Gray16(_) => Err(PyTypeError::new_err(format!("{what}: metrics take 8-bit images"))),
    }
}

/// Fusion metrics of `fused` against its sources (`fusion eval`): a dict of name -> value,
/// with the names of the CLI's CSV header. suite: "vifb" (VIFB's 13 metrics exactly as its
/// MATLAB code computes them; colour per channel), "study" (AG, MI, FMI, SSIM, RMSE and
/// Haghighat's FMIs), "all" (both, names prefixed "study." / "vifb."). The sources are brought
/// onto the fused grid first (VIS area, TIR bicubic). NaN where the reference code is undefined.
#[pyfunction]
#[pyo3(name = "eval", signature = (vis, tir, fused, suite="vifb"))]
fn eval_metrics<'py>(
    py: Python<'py>,
    vis: &Bound<'py, PyAny>,
    tir: &Bound<'py, PyAny>,
    fused: &Bound<'py, PyAny>,
    suite: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let suite = named::<Suite>("suite", suite)?;
    let (v, t, f) = (channels_arg("vis", vis)?, channels_arg("tir", tir)?, channels_arg("fused", fused)?);
    let table = py.detach(|| fusion_metrics::table::score_images(suite, &v, &t, &f)).map_err(py_err)?;
    let d = PyDict::new(py);
    for (name, value) in &table.rows {
        d.set_item(name, *value)?;
    }
    Ok(d)
}

/// Reads an image file (PNG, JPEG, TIFF, PGM/PPM): uint8 (H, W) or (H, W, 3), or uint16 (H, W).
#[pyfunction]
fn load(py: Python<'_>, path: PathBuf) -> PyResult<Py<PyAny>> {
    let picture = py.detach(|| fusion_io::load_picture(&path)).map_err(py_err)?;
    Ok(match picture {
        fusion_io::Picture::Gray8(g) => {
            g.data.into_pyarray(py).reshape([g.height, g.width])?.into_any().unbind()
        }
        fusion_io::Picture::Gray16(g) => {
            g.data.into_pyarray(py).reshape([g.height, g.width])?.into_any().unbind()
        }
        fusion_io::Picture::Rgb8(c) => {
            c.interleaved().into_pyarray(py).reshape([c.height, c.width, 3])?.into_any().unbind()
        }
    })
}

/// Writes an image by its extension (`.png`, `.tif`/`.tiff`, `.pgm` for grey), atomically:
/// the file appears whole or not at all.
#[pyfunction]
fn save(py: Python<'_>, path: PathBuf, img: &Bound<'_, PyAny>) -> PyResult<()> {
    match Image::of("img", img)? {
        Image::Gray8(a) => {
            let g = Plane::of(a.as_array()).to_gray().map_err(py_err)?;
            py.detach(|| fusion_io::save_gray_u8(&path, &g)).map_err(py_err)
        }
        Image::Gray16(a) => {
            let g = Plane::of(a.as_array()).to_gray().map_err(py_err)?;
            py.detach(|| fusion_io::save_gray_u16(&path, &g)).map_err(py_err)
        }
        Image::Rgb8(a) => {
            let c = channels_of(&a).map_err(py_err)?;
            py.detach(|| -> anyhow::Result<()> {
                let format = fusion_io::OutFormat::of(&path)?;
                fusion_io::write_atomic(&path, |w| fusion_io::encode_channels(w, format, &c))
            })
            .map_err(py_err)
        }
    }
}

/// Renders a dataset (`fusion render`) or a rendezvous sequence (sequence="approach",
/// "flyaround" or "radial": the Earth behind the target) into the folder `out` (a new folder appears whole or not at all; an existing
/// one is written into) and returns its manifest, the
/// parsed `manifest.json`: per frame the files, the camera pose and the illumination phase.
/// frames: how many (default: the CLI's); tir_sizes: thermal frame sizes (default: half the VIS
/// size and the VIS size; a sequence renders the first, half the VIS size); tir16:
/// also write 16-bit thermal counts; target: "tango" (the Tango-like small satellite) or
/// "boxwing" (a box-wing satellite with two long solar wings).
#[pyfunction]
#[pyo3(signature = (out, frames=None, sequence=None, seed=1, vis_size=1024, tir_sizes=None, tir16=false, target="tango"))]
#[allow(clippy::too_many_arguments)]
fn render<'py>(
    py: Python<'py>,
    out: PathBuf,
    frames: Option<usize>,
    sequence: Option<&str>,
    seed: u64,
    vis_size: u32,
    tir_sizes: Option<Vec<u32>>,
    tir16: bool,
    target: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let defaults = render_host::RenderOptions::default();
    let options = render_host::RenderOptions {
        out: out.clone(),
        frames,
        sequence: sequence
            .map(|s| named::<render_host::sequence::SequenceName>("sequence", s))
            .transpose()?,
        seed,
        vis_size,
        tir_sizes,
        tir16,
        target: named::<render_host::scene::Target>("target", target)?,
        ..defaults
    };
    let manifest = py
        .detach(|| -> anyhow::Result<String> {
            fusion_io::console::set_quiet(true);
            render_host::render(&options)?;
            let path = out.join("manifest.json");
            std::fs::read_to_string(&path).with_context(|| format!("cannot read {}", path.display()))
        })
        .map_err(py_err)?;
    py.import("json")?.call_method1("loads", (manifest,))
}

/// Corrects raw 14/16-bit thermal counts with the core's front end, as `fusion fuse --nuc
/// --bad-pixels --shutter --column-filter` does before its AGC; returns uint16 (H, W).
///
/// raw: uint16 (H, W) counts. nuc: path of the camera's NUC tables (the `VISTNUC1` file the
///   renderer writes as calibration/tir.nuc). bad_pixels: path of its bad-pixel map (8-bit
///   image, non-zero = bad). shutter: uint16 (H, W) raw counts of a flat field, re-levelling the
///   tables' offsets first (needs nuc). column_filter: a threshold in counts, or "auto".
#[pyfunction]
#[pyo3(signature = (raw, *, nuc=None, bad_pixels=None, shutter=None, column_filter=None))]
fn correct_thermal<'py>(
    py: Python<'py>,
    raw: PyReadonlyArray2<'py, u16>,
    nuc: Option<PathBuf>,
    bad_pixels: Option<PathBuf>,
    shutter: Option<PyReadonlyArray2<'py, u16>>,
    column_filter: Option<&Bound<'py, PyAny>>,
) -> PyResult<Py<PyAny>> {
    let column = match column_filter {
        None => None,
        Some(c) => Some(match c.extract::<String>() {
            Ok(s) if s == "auto" => None,
            Ok(s) => {
                return Err(PyValueError::new_err(format!("column_filter {s:?} is not \"auto\" or a count")));
            }
            Err(_) => Some(c.extract::<u16>().map_err(|_| {
                PyValueError::new_err("column_filter: a threshold of 1 to 32767 counts, or \"auto\"")
            })?),
        }),
    };
    if shutter.is_some() && nuc.is_none() {
        return Err(PyValueError::new_err("shutter= re-levels the NUC offsets: give nuc= too"));
    }
    let raw = Plane::of(raw.as_array()).to_gray().map_err(py_err)?;
    let shutter = shutter.map(|s| Plane::of(s.as_array()).to_gray()).transpose().map_err(py_err)?;
    let (h, w) = (raw.height, raw.width);
    let out = py
        .detach(|| -> anyhow::Result<Vec<u16>> {
            use fusion_engine::thermal::{COLUMN_RADIUS, Column, ThermalChain};
            let (tables, map) = fusion_engine::thermal::load(nuc.as_deref(), bad_pixels.as_deref())?;
            // `column`: None without the filter; Some(None) for "auto".
            let column = column.map(|fixed| match fixed {
                Some(threshold) => Column::Params(fusion_nostd::thermal::ColumnParams {
                    threshold,
                    radius: COLUMN_RADIUS,
                    smoothing: 0,
                }),
                None => Column::Auto { radius: COLUMN_RADIUS, smoothing: 0 },
            });
            let mut chain = ThermalChain::new(tables, map, column)?;
            if let Some(s) = &shutter {
                chain.shutter(s)?;
            }
            Ok(chain.correct(&raw)?.data)
        })
        .map_err(py_err)?;
    let arr = numpy::ndarray::Array2::from_shape_vec((h, w), out)
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    Ok(numpy::PyArray2::from_owned_array(py, arr).into_any().unbind())
}

/// Warps a thermal image of an offset camera pair onto the visible grid for a target at
/// `range` metres, as `fusion register` does (the core's `fusion_nostd::registration`);
/// returns the visible camera's size, same dtype.
///
/// img: uint8 or uint16 (H, W), the rig's thermal size. rig: path of the pair's calibration
///   (OpenCV `FileStorage` YAML or JSON: camera_matrix_vis, dist_coeffs_vis, image_size_vis,
///   the same with _tir, R, T; `X_tir = R·X_vis + T`, metres). interp: "linear" or "cubic".
///   border: "constant" (border_value, 0 by default) or "replicate".
#[pyfunction]
#[pyo3(signature = (img, *, rig, range, interp="linear", border="constant", border_value=0))]
fn register<'py>(
    py: Python<'py>,
    img: &Bound<'py, PyAny>,
    rig: PathBuf,
    range: f64,
    interp: &str,
    border: &str,
    border_value: u16,
) -> PyResult<Py<PyAny>> {
    use fusion_engine::registration::{BorderArg, InterpolationArg};
    let interp: fusion_nostd::registration::Interpolation =
        named::<InterpolationArg>("interp", interp)?.into();
    let border = named::<BorderArg>("border", border)?.with_value(border_value);
    let rig = fusion_io::rig::read(&rig).map_err(py_err)?;
    fn run<'py, T: fusion_nostd::registration::RemapSample + numpy::Element + Default + Send + Sync>(
        py: Python<'py>,
        src: &PyReadonlyArray2<'py, T>,
        rig: &fusion_nostd::registration::Rig,
        range: f64,
        interp: fusion_nostd::registration::Interpolation,
        border: fusion_nostd::registration::Border,
    ) -> PyResult<Py<PyAny>> {
        let tir = Plane::of(src.as_array()).to_gray().map_err(py_err)?;
        let out = py
            .detach(|| fusion_engine::registration::register(&tir, rig, range, interp, border))
            .map_err(py_err)?;
        let arr = numpy::ndarray::Array2::from_shape_vec((out.height, out.width), out.data)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(numpy::PyArray2::from_owned_array(py, arr).into_any().unbind())
    }
    match Image::of("img", img)? {
        Image::Gray8(a) => run(py, &a, &rig, range, interp, border),
        Image::Gray16(a) => run(py, &a, &rig, range, interp, border),
        Image::Rgb8(_) => {
            Err(PyTypeError::new_err("img: register takes a grey (H, W) uint8 or uint16 array"))
        }
    }
}

/// The cases of a campaign file (`fusion campaign plan FILE --json`), the plan's fingerprint and
/// its table (as `fusion campaign plan FILE` prints it): JSON text `{"name", "fingerprint",
/// "table", "cases": [...]}` (`vistir.campaign` parses it).
#[pyfunction]
fn _campaign_plan(py: Python<'_>, path: PathBuf) -> PyResult<String> {
    py.detach(|| -> anyhow::Result<String> {
        let file = fusion_campaign::file::CampaignFile::read(&path)?;
        let cases = fusion_campaign::plan::plan(&file)?;
        let fingerprint = fusion_campaign::plan::fingerprint(&file.name, &cases);
        Ok(serde_json::to_string(&serde_json::json!({
            "name": file.name,
            "fingerprint": fingerprint,
            "table": fusion_campaign::plan::table(&file.name, &cases),
            "cases": cases,
        }))?)
    })
    .map_err(py_err)
}

/// Runs one campaign case (its JSON, as planned): renders its sequence into a scratch folder
/// under `scratch` (removed afterwards), judges every stream; returns its rows as JSON text.
/// `threads`: the worker threads it may use (0: every core).
#[pyfunction]
#[pyo3(signature = (case, scratch, threads=0))]
fn _campaign_case(py: Python<'_>, case: &str, scratch: PathBuf, threads: usize) -> PyResult<String> {
    let case: fusion_campaign::plan::Case =
        serde_json::from_str(case).map_err(|e| PyValueError::new_err(format!("not a campaign case: {e}")))?;
    py.detach(|| -> anyhow::Result<String> {
        fusion_io::console::set_quiet(true);
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
        let rows = pool.install(|| fusion_campaign::case::run(&case, &scratch))?;
        Ok(serde_json::to_string(&rows)?)
    })
    .map_err(py_err)
}

/// VIS/TIR image fusion for spacecraft navigation: the flight core, the metrics and the
/// renderer from Python.
#[pymodule]
fn _vistir(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    // What a campaign records as the code that produced its results: the package version and
    // the commit it was built from (`+dirty` with uncommitted changes), from build.rs.
    m.add("_code_version", concat!(env!("CARGO_PKG_VERSION"), "+", env!("VISTIR_GIT_REV")))?;
    m.add_function(wrap_pyfunction!(_campaign_plan, m)?)?;
    m.add_function(wrap_pyfunction!(_campaign_case, m)?)?;
    m.add_function(wrap_pyfunction!(fuse, m)?)?;
    m.add_class::<Sequence>()?;
    m.add_function(wrap_pyfunction!(rescale, m)?)?;
    m.add_function(wrap_pyfunction!(correct_thermal, m)?)?;
    m.add_function(wrap_pyfunction!(register, m)?)?;
    m.add_function(wrap_pyfunction!(eval_metrics, m)?)?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(save, m)?)?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    Ok(())
}
