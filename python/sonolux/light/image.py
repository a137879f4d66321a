"""From linear radiance to image files: exposure, tone map, sRGB, and the writers.

- Exposure, automatic, then shifted by EV stops (``--exposure``): by default an incident-light
  meter, ``scale = 0.6 / Ē`` where Ē is the log-average of E / π (the radiance of a white
  Lambertian surface) over the surfaces in view (:func:`sonolux.light.render.incident_exposure`),
  so white looks white and a dark floor dark; or a reflected-light meter from the key value,
  ``scale = 0.18 / L̄``, where L̄ is the picture's log-average luminance exp(mean(log(δ + Y)))
  (Reinhard et al. 2002), which makes every picture middle grey on average.
- Tone maps: ``aces`` (the filmic curve of Narkowicz's fit to ACES, the default) or
  ``reinhard`` (x / (1 + x)), per channel; then the sRGB transfer curve.
- Files: PNG (8-bit sRGB) with Pillow; linear HDR as PFM (float32 RGB, little-endian, rows
  bottom to top: a header and raw floats, written with numpy) or OpenEXR (float32,
  ZIP, through the ``OpenEXR`` package when it is installed). Every file is written to a
  temporary name beside it and renamed.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from sonolux.errors import SonoluxError
from sonolux.light.photometry import LUMINANCE_RGB
from sonolux.outputs import write_atomically

KEY_VALUE = 0.18
#: The incident meter exposes a white Lambertian surface under the average light to this value:
#: the 0.6 that Narkowicz's ACES fit expects before it, so white lands at 84 % sRGB with
#: headroom above it for the brighter walls, and an 18 % grey card at 0.108.
INCIDENT_WHITE = 0.6
LOG_DELTA = 1e-6
TONE_MAPS = ("aces", "reinhard")
HDR_SUFFIXES = (".pfm", ".exr")


def luminance(rgb: np.ndarray) -> np.ndarray:
    return rgb @ LUMINANCE_RGB


def auto_exposure(linear: np.ndarray, mask: np.ndarray | None = None) -> float:
    """0.18 / the log-average luminance of the pixels in ``mask`` (all when None)."""
    y = luminance(np.asarray(linear, np.float64))
    if mask is not None:
        y = y[mask]
    y = y[np.isfinite(y)]
    if y.size == 0:
        return 1.0
    log_avg = float(np.exp(np.mean(np.log(LOG_DELTA + np.maximum(y, 0.0)))))
    return KEY_VALUE / max(log_avg, LOG_DELTA)


def tone_map(x: np.ndarray, curve: str = "aces") -> np.ndarray:
    """Exposed linear values to [0, 1], per channel."""
    x = np.maximum(np.asarray(x, np.float64), 0.0)
    if curve == "aces":
        y = x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14)
    elif curve == "reinhard":
        y = x / (1.0 + x)
    else:
        raise SonoluxError(f"tone map {curve!r} is not allowed: " + " or ".join(TONE_MAPS))
    return np.clip(y, 0.0, 1.0)


def srgb_encode(y: np.ndarray) -> np.ndarray:
    """Linear [0, 1] to the sRGB transfer curve."""
    y = np.clip(y, 0.0, 1.0)
    return np.where(y <= 0.0031308, 12.92 * y, 1.055 * np.power(y, 1 / 2.4) - 0.055)


def to_srgb8(linear: np.ndarray, scale: float, curve: str = "aces",
             samples_axis: int | None = None) -> np.ndarray:
    """uint8[..., 3]: exposed by ``scale``, tone-mapped and sRGB-encoded. With
    ``samples_axis`` (e.g. 2 for float[H, W, S, 3]) the samples are tone-mapped first and
    averaged after, as a display resolves them: a pixel a quarter covered by a light that is
    30 times brighter than the wall is then a quarter white, not white."""
    mapped = tone_map(linear * scale, curve)
    if samples_axis is not None:
        mapped = mapped.mean(axis=samples_axis)
    return np.round(srgb_encode(mapped) * 255).astype(np.uint8)


def _atomic(path: str | Path, write: Callable[[str], None]) -> Path:
    return write_atomically(path, lambda tmp: write(str(tmp)))


#: The picture formats by suffix: the file holds what its name says.
PICTURE_FORMATS = {".png": "PNG", ".jpg": "JPEG", ".jpeg": "JPEG"}


def picture_format(path: str | Path) -> str:
    """The format of a picture file by its suffix, or an error naming the path."""
    fmt = PICTURE_FORMATS.get(Path(path).suffix.lower())
    if fmt is None:
        raise SonoluxError(f"{path}: a picture is written as .png, .jpg or .jpeg (the format "
                           "follows the name)")
    return fmt


def write_png(path: str | Path, srgb8: np.ndarray) -> Path:
    """Writes sRGB uint8[h, w, 3] as PNG, or as JPEG (quality 92) when the name says .jpg."""
    from PIL import Image

    fmt = picture_format(path)
    extra = {"quality": 92} if fmt == "JPEG" else {}
    return _atomic(path, lambda tmp: Image.fromarray(srgb8, "RGB").save(tmp, format=fmt, **extra))


def hdr_format(path: str | Path) -> str:
    """The suffix of an HDR image (.pfm or .exr), or an error naming the path."""
    suffix = Path(path).suffix.lower()
    if suffix not in HDR_SUFFIXES:
        raise SonoluxError(f"{path}: an HDR image must end in " + " or ".join(HDR_SUFFIXES))
    return suffix


def write_hdr(path: str | Path, linear: np.ndarray) -> Path:
    """Linear float32 RGB as .pfm or .exr (by the suffix)."""
    suffix = Path(path).suffix.lower()
    rgb = np.ascontiguousarray(linear, np.float32)
    if suffix == ".pfm":
        def write(tmp: str) -> None:
            h, w = rgb.shape[:2]
            with open(tmp, "wb") as f:
                f.write(f"PF\n{w} {h}\n-1.0\n".encode("ascii"))  # negative scale: little-endian
                f.write(rgb[::-1].astype("<f4").tobytes())
        return _atomic(path, write)
    if suffix == ".exr":
        try:
            import OpenEXR
        except ImportError:
            raise SonoluxError(f"{path}: writing EXR needs the OpenEXR package (pip install "
                               "OpenEXR, or sonolux[exr]); or write a .pfm") from None

        def write_exr(tmp: str) -> None:
            header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
            with OpenEXR.File(header, {"RGB": rgb}) as f:
                f.write(tmp)
        return _atomic(path, write_exr)
    raise SonoluxError(f"{path}: an HDR image must end in " + " or ".join(HDR_SUFFIXES))


def read_pfm(path: str | Path) -> np.ndarray:
    """float32[H, W, 3] from a colour PFM (for tests and comparisons)."""
    data = Path(path).read_bytes()
    parts = data.split(b"\n", 3)
    if parts[0] != b"PF":
        raise SonoluxError(f"{path}: not a colour PFM file")
    w, h = (int(v) for v in parts[1].split())
    endian = "<" if float(parts[2]) < 0 else ">"
    return np.frombuffer(parts[3], dtype=f"{endian}f4").reshape(h, w, 3)[::-1].copy()
