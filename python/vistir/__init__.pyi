"""VIS/TIR image fusion for spacecraft navigation: the flight core, the metrics and the
renderer of the `fusion` project, with numpy arrays. Results are the `fusion` CLI's, bit for bit.
"""

from os import PathLike
from typing import Any, Literal, Optional, Sequence, Tuple, Union, overload

import numpy as np
import numpy.typing as npt

__version__: str

Gray8 = npt.NDArray[np.uint8]  # (H, W)
Gray16 = npt.NDArray[np.uint16]  # (H, W) thermal counts
Rgb8 = npt.NDArray[np.uint8]  # (H, W, 3)
Method = Literal["adf", "tsifsd", "ifevip", "adaptive"]
VariantName = Literal["flight", "classic"]
RescaleName = Literal["tir-up", "vis-down", "none"]
SkipName = Literal["none", "roi", "all"]
AgcName = Literal["linear", "plateau"]
Path = Union[str, PathLike[str]]

@overload
def fuse(
    vis: Union[Gray8, Rgb8],
    tir: Union[Gray8, Gray16],
    method: Method = "tsifsd",
    variant: VariantName = "flight",
    rescale: RescaleName = "tir-up",
    skip: SkipName = "none",
    *,
    agc: AgcName = "linear",
    plateau: Optional[int] = None,
    strips: Optional[int] = None,
    window: Optional[Tuple[int, int, int, int]] = None,
    report: Literal[False] = False,
) -> npt.NDArray[np.uint8]: ...
@overload
def fuse(
    vis: Union[Gray8, Rgb8],
    tir: Union[Gray8, Gray16],
    method: Method = "tsifsd",
    variant: VariantName = "flight",
    rescale: RescaleName = "tir-up",
    skip: SkipName = "none",
    *,
    agc: AgcName = "linear",
    plateau: Optional[int] = None,
    strips: Optional[int] = None,
    window: Optional[Tuple[int, int, int, int]] = None,
    report: Literal[True],
) -> Tuple[npt.NDArray[np.uint8], dict[str, Any]]:
    """Fuses a visible and a thermal frame: the same bytes as `fusion fuse`.

    vis: uint8 (H, W) grey or (H, W, 3) RGB (the luminance is fused and the colour kept: the
    result is then (H, W, 3)). tir: uint8 (h, w), or uint16 (h, w) thermal counts mapped to 8
    bits by the core AGC first. The output is on the VIS grid for rescale="tir-up", on the TIR
    grid for "vis-down". strips=N fuses in the 512 KiB strip working set (at most N rows a
    strip): the same bytes. report=True also returns a dict: grid, rescaled, guards,
    guard_bits, skip_taken, skip_declined, illumination, window, background.

    Raises TypeError for another dtype or shape, ValueError with the core's message for sizes
    or names it refuses. The GIL is released while the core runs.
    """

def rescale(
    img: Union[Gray8, Gray16], width: int, height: int, filter: Literal["cubic", "area"] = "cubic"
) -> Union[Gray8, Gray16]:
    """Rescales a grey image with the core's rescalers (cv2.INTER_CUBIC / cv2.INTER_AREA
    semantics, bit-exact with OpenCV at factor 2); returns (height, width) of the same dtype."""

class Sequence:
    """A sequence of frame pairs fused in order with the core's sequence mode: ADF's KL weights
    carried from each frame to the next (one pass over the strips); the first frame, and one
    whose VIS illumination class, covariance size (more than size_change_percent per cent) or
    parameters changed, takes its own weights; the other methods are fused per frame. The same
    bytes as `fusion fuse --sequence-mode` on folders of the frames in name order.
    """

    def __init__(
        self,
        method: Method = "adf",
        variant: VariantName = "flight",
        rescale: RescaleName = "tir-up",
        skip: SkipName = "none",
        *,
        agc: AgcName = "linear",
        plateau: Optional[int] = None,
        strips: Optional[int] = None,
        window: Optional[Tuple[int, int, int, int]] = None,
        size_change_percent: int = 150,
        window_frames: int = 5,
    ) -> None: ...
    @overload
    def fuse(self, vis: Union[Gray8, Rgb8], tir: Union[Gray8, Gray16], report: Literal[False] = False) -> npt.NDArray[np.uint8]: ...
    @overload
    def fuse(
        self, vis: Union[Gray8, Rgb8], tir: Union[Gray8, Gray16], report: Literal[True]
    ) -> Tuple[npt.NDArray[np.uint8], dict[str, Any]]:
        """Fuses the next pair as `vistir.fuse` would with these options, the weights carried;
        report=True adds "pass" ("carried", "own", "per-frame"), "restart" ("first",
        "illumination", "size", "method" or None), "p_ir_used" and "p_ir_own" to fuse's dict."""
    def reset(self) -> None:
        """Forgets the carried weights: the next frame takes its own."""

def correct_thermal(
    raw: Gray16,
    *,
    nuc: Optional[Path] = None,
    bad_pixels: Optional[Path] = None,
    shutter: Optional[Gray16] = None,
    column_filter: Union[None, int, Literal["auto"]] = None,
) -> Gray16:
    """Corrects raw 14/16-bit thermal counts with the core's front end (`fusion fuse --nuc
    --bad-pixels --shutter --column-filter` before its AGC): the NUC tables and bad-pixel map
    files, a flat-field shutter frame re-levelling the offsets, the column filter's threshold in
    counts or "auto"; returns uint16 (H, W), ready for `fuse`."""

def register(
    img: Union[Gray8, Gray16],
    *,
    rig: Path,
    range: float,
    interp: Literal["linear", "cubic"] = "linear",
    border: Literal["constant", "replicate"] = "constant",
    border_value: int = 0,
) -> Union[Gray8, Gray16]:
    """Warps a thermal image of an offset camera pair onto the visible grid for a target at
    `range` metres (`fusion register`): `rig` is the pair's OpenCV stereo calibration (YAML or
    JSON; camera 1 = VIS, X_tir = R X_vis + T). Returns the visible camera's size, same dtype."""

def eval(
    vis: Union[Gray8, Rgb8],
    tir: Union[Gray8, Rgb8],
    fused: Union[Gray8, Rgb8],
    suite: Literal["vifb", "study", "all"] = "vifb",
) -> dict[str, float]:
    """Fusion metrics of `fused` against its sources (`fusion eval`), named as the CLI's CSV
    header: VIFB's 13 (AG, CE, EI, EN, MI, PSNR, Qabf, Qcb, Qcv, RMSE, SF, SSIM, SD) exactly as
    VIFB's MATLAB code computes them, the study's suite, or both. NaN where undefined."""

def load(path: Path) -> Union[Gray8, Gray16, Rgb8]:
    """Reads a PNG, JPEG, TIFF or PGM/PPM: uint8 (H, W) or (H, W, 3), or uint16 (H, W)."""

def save(path: Path, img: Union[Gray8, Gray16, Rgb8]) -> None:
    """Writes .png, .tif/.tiff or .pgm (grey) by the extension; the file appears whole or not at all."""

def render(
    out: Path,
    frames: Optional[int] = None,
    sequence: Optional[Literal["approach", "flyaround", "radial"]] = None,
    seed: int = 1,
    vis_size: int = 1024,
    tir_sizes: Optional[Sequence[int]] = None,
    tir16: bool = False,
    target: Literal["tango", "boxwing"] = "tango",
) -> dict[str, Any]:
    """Renders a dataset or a rendezvous sequence (with ground truth) into the folder `out` (a
    new folder appears whole or not at all) and returns its manifest (the parsed manifest.json);
    `target` picks the procedural target."""
