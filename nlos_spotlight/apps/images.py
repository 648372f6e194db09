"""Read photographs for ``nlos predict``: linear radiance frames at the network's resolution.

Inputs and how they become linear RGB (the NLOS network divides every image by its mean, so only
relative radiance matters; absolute exposure does not):

- ``.npy``: float linear radiance, (H, W, 3) for one frame or (N, H, W, 3) for a stack.
- PNG / JPEG, 8 or 16 bits per channel (gray, gray+alpha, RGB, RGBA; alpha dropped, gray
  replicated): integers divided by 255 or 65535, then the sRGB transfer curve undone (IEC
  61966-2-1) unless ``linear=True`` (for cameras that write linear values). Pillow decodes 8-bit
  files; it truncates 16-bit RGB PNGs to 8 bits, so those go through libpng (:func:`read_png16`).
- A video (``VIDEO_SUFFIXES``) through ``imageio`` when it is installed (optional), decoded as
  8-bit sRGB.

Every frame is then resampled to the checkpoint's (H, W) by area averaging (:func:`area_resize`):
an output pixel is the mean of the input over its footprint, the same pixel model the renderer
uses (DESIGN section 4). The whole frame is resampled; a frame of another aspect ratio is
stretched, so crop to the training aspect first.
"""

from __future__ import annotations

import glob
from collections import Counter
import re
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator

import numpy as np

from ..errors import NlosError
from ..render.color import srgb_to_linear

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg")
"""Still images read by :func:`read_image`."""
VIDEO_SUFFIXES = (".mp4", ".avi", ".mov", ".mkv", ".webm", ".m4v", ".mpg", ".mpeg", ".wmv", ".gif")
"""Files read as video through ``imageio``."""
_PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


# ---------------------------------------------------------------- pixel values

def _to_rgb(a: np.ndarray, where: str) -> np.ndarray:
    """(H, W), (H, W, 1..4) -> (H, W, 3): gray replicated, alpha dropped."""
    if a.ndim == 2:
        a = a[..., None]
    if a.ndim != 3 or a.shape[2] not in (1, 2, 3, 4):
        raise NlosError(f"{where}: unsupported image layout {a.shape}")
    if a.shape[2] in (1, 2):  # gray (+ alpha)
        return np.repeat(a[..., :1], 3, axis=2)
    return a[..., :3]


# ---------------------------------------------------------------- 16-bit PNG

def read_png16(path: Path) -> np.ndarray:
    """Decode a 16-bit PNG (gray, gray+alpha, RGB, RGBA) -> (H, W, C) uint16, through libpng
    (``imagecodecs``): a camera-sized frame in well under a second."""
    import imagecodecs

    data = path.read_bytes()
    where = str(path)
    if not data.startswith(_PNG_MAGIC):
        raise NlosError(f"{where}: not a PNG file")
    if len(data) < 33 or data[12:16] != b"IHDR":
        raise NlosError(f"{where}: PNG without header")
    width, height, depth, color = struct.unpack(">IIBB", data[16:26])
    if depth != 16 or color not in (0, 2, 4, 6):
        raise NlosError(f"{where}: expected a 16-bit gray/RGB(A) PNG, got depth {depth}, color type {color}")
    if width * height > 200_000_000:  # checked before the decoder allocates it
        raise NlosError(f"{where}: {width} x {height} pixels is too large a frame")
    try:
        a = imagecodecs.png_decode(data)
    except Exception as exc:  # libpng's errors: truncated or corrupted data, bad CRCs
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise NlosError(f"{where}: corrupted PNG ({msg})") from None
    a = np.asarray(a)
    if a.dtype != np.uint16 or a.shape[:2] != (height, width):
        raise NlosError(f"{where}: corrupted PNG (decoded {a.dtype} {a.shape}, header says {height} x {width})")
    return a.reshape(height, width, -1)


def _png_depth(path: Path) -> int | None:
    """Bit depth from a PNG's header, None for other files."""
    with path.open("rb") as f:
        head = f.read(33)
    if not head.startswith(_PNG_MAGIC) or len(head) < 25 or head[12:16] != b"IHDR":
        return None
    return head[24]


# ---------------------------------------------------------------- readers

def read_image(path: Path, linear: bool = False) -> np.ndarray:
    """A PNG / JPEG photograph -> (H, W, 3) float64 linear values in [0, 1] (see module docstring)."""
    try:
        if _png_depth(path) == 16:
            a, full = read_png16(path), 65535.0
        else:
            from PIL import Image, UnidentifiedImageError

            try:
                with Image.open(path) as im:
                    im.load()
                    if im.mode in ("I;16", "I;16B", "I;16L", "I"):  # 16-bit gray from other containers
                        a, full = np.asarray(im, dtype=np.float64), 65535.0
                    else:
                        a, full = np.asarray(im.convert("RGBA" if "A" in im.mode else "RGB")), 255.0
            except Image.DecompressionBombError:
                raise NlosError(f"{path}: image too large (over {Image.MAX_IMAGE_PIXELS:,} pixels: a damaged "
                                "or hostile file)") from None
            except (UnidentifiedImageError, SyntaxError, ValueError, OSError) as exc:
                raise NlosError(f"{path}: unreadable image ({type(exc).__name__})") from None
    except FileNotFoundError:
        raise NlosError(f"{path}: file not found") from None
    v = _to_rgb(np.asarray(a, dtype=np.float64), str(path)) / full
    return v if linear else srgb_to_linear(v)


def read_npy(path: Path) -> np.ndarray:
    """(H, W, 3) or (N, H, W, 3) float radiance -> (N, H, W, 3) float64."""
    try:
        a = np.load(path, allow_pickle=False)
    except FileNotFoundError:
        raise NlosError(f"{path}: file not found") from None
    except Exception as exc:  # np.load raises several types on foreign or torn files
        raise NlosError(f"{path}: unreadable .npy ({type(exc).__name__})") from None
    if not isinstance(a, np.ndarray) or a.dtype.kind not in "fiu":
        raise NlosError(f"{path}: expected a numeric array, got dtype {getattr(a, 'dtype', type(a))}")
    if a.ndim == 3:
        a = a[None]
    if a.ndim != 4 or a.shape[-1] != 3 or min(a.shape) == 0:
        raise NlosError(f"{path}: expected shape (H, W, 3) or (N, H, W, 3), got {a.shape}")
    return a.astype(np.float64)


def read_video(path: Path, linear: bool = False) -> tuple[Iterator[np.ndarray], float | None]:
    """Frames of a video as (H, W, 3) float64 linear values, and its frame rate (None if unknown)."""
    try:
        import imageio.v3 as iio
    except ImportError:
        raise NlosError(f"{path}: reading video needs the optional package imageio with a video plugin "
                        "(pip install 'imageio[pyav]'), or pass the frames as images") from None
    if not path.is_file():
        raise NlosError(f"{path}: file not found")
    try:
        meta = iio.immeta(path)
        fps = meta.get("fps")
        frames = iio.imiter(path)
    except Exception as exc:  # plugins raise many types on unreadable files
        raise NlosError(f"{path}: imageio cannot read this video ({type(exc).__name__})") from None

    def gen() -> Iterator[np.ndarray]:
        try:
            for f in frames:
                a = np.asarray(f)
                full = 65535.0 if a.dtype == np.uint16 else 255.0
                v = _to_rgb(a.astype(np.float64), str(path)) / full
                yield v if linear else srgb_to_linear(v)
        except NlosError:
            raise
        except Exception as exc:
            raise NlosError(f"{path}: video decoding failed ({type(exc).__name__})") from None

    return gen(), float(fps) if fps else None


# ---------------------------------------------------------------- resampling

def _area_matrix(n_in: int, n_out: int) -> np.ndarray:
    """(n_out, n_in) weights: output cell i is the mean of the input over its footprint
    [i, i+1) * n_in / n_out, each input cell weighted by its overlap."""
    edges = np.arange(n_out + 1) * (n_in / n_out)
    lo, hi = edges[:-1, None], edges[1:, None]
    cells = np.arange(n_in)[None, :]
    overlap = np.clip(np.minimum(hi, cells + 1) - np.maximum(lo, cells), 0.0, None)
    return overlap / overlap.sum(axis=1, keepdims=True)


def area_resize(images: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Area-averaging resampling (exact box filter; works for down- and upsampling).

    Args:
        images: (N, H, W, C) or (H, W, C) values.
        shape: (h, w) output size.

    Returns:
        (N, h, w, C) (or (h, w, C)) float64; an integer downscale is the mean of each block.
    """
    a = np.asarray(images, dtype=np.float64)
    single = a.ndim == 3
    a = a[None] if single else a
    h, w = shape
    if a.shape[1:3] != (h, w):
        # two matrix products (rows, then columns): a three-operand einsum without a contraction
        # order loops over every (i, j, h, w) and took a minute for a camera-sized frame
        n, c = a.shape[0], a.shape[-1]
        a = np.matmul(_area_matrix(a.shape[1], h), a.reshape(n, a.shape[1], -1)).reshape(n, h, -1, c)
        a = np.einsum("jw,nhwc->nhjc", _area_matrix(a.shape[2], w), a, optimize=True)
    return a[0] if single else a


# ---------------------------------------------------------------- frame sets

@dataclass
class Frames:
    """Input frames at the network's resolution, in time order."""

    images: np.ndarray
    """(N, H, W, 3) float32 linear radiance (relative)."""
    sources: list[str] = field(default_factory=list)
    """(N,) where each frame came from: 'a.png', 'stack.npy[3]', 'clip.mp4#12'."""
    fps: float | None = None
    """Frames per second (--fps, else the video's rate), None if unknown."""
    native_shapes: list[tuple[int, int]] = field(default_factory=list)
    """Distinct (H, W) sizes of the inputs before resampling."""
    clipped: np.ndarray | None = None
    """(N, H, W) bool: some input pixel under the frame's pixel sat at the file's largest code (the
    camera clipped there; the networks read this flag, DESIGN section 6). None for .npy inputs."""

    def __len__(self) -> int:
        return len(self.images)

    def bursts(self, k: int) -> "Frames":
        """Consecutive groups of ``k`` frames averaged (a still capture's burst); k must divide N."""
        if k < 1:
            raise NlosError(f"--burst: expected a positive frame count, got {k}")
        if len(self) % k:
            raise NlosError(f"--burst {k}: {len(self)} frames do not split into bursts of {k}")
        if k == 1:
            return self
        n = len(self) // k
        images = self.images.reshape(n, k, *self.images.shape[1:]).mean(axis=1, dtype=np.float64)
        sources = [f"{self.sources[i * k]}..{self.sources[i * k + k - 1]}" for i in range(n)]
        clipped = None if self.clipped is None else self.clipped.reshape(n, k, *self.clipped.shape[1:]).any(axis=1)
        return Frames(images.astype(np.float32), sources, None if self.fps is None else self.fps / k,
                      list(self.native_shapes), clipped)


def _natural_key(p: Path) -> list:
    """Sort key comparing digit runs as numbers: frame2 < frame10."""
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", str(p))]


def _printf_files(pattern: str) -> list[Path]:
    """Files matching a printf pattern such as ``frames/img_%04d.png``."""
    p = Path(pattern)
    regex = re.escape(p.name)
    regex = re.sub(r"%0(\d+)d", lambda m: rf"\d{{{m.group(1)}}}", regex.replace(r"\%", "%"))
    regex = regex.replace("%d", r"\d+")
    folder = p.parent if str(p.parent) else Path(".")
    return [f for f in folder.glob("*") if re.fullmatch(regex, f.name)] if folder.is_dir() else []


def expand_inputs(items: list[str]) -> list[Path]:
    """Input arguments -> files in frame order.

    Each item is a file, a directory (its images and .npy files), a printf pattern
    (``img_%04d.png``) or a glob (``'frames/*.png'``). Files are ordered by name with numbers
    compared numerically (``frame2`` before ``frame10``), so a numbered sequence plays in order.
    """
    files: list[Path] = []
    for item in items:
        p = Path(item)
        if p.is_dir():
            found = [f for f in p.iterdir() if f.suffix.lower() in (*IMAGE_SUFFIXES, ".npy")]
            if not found:
                raise NlosError(f"{p}: directory holds no .png, .jpg or .npy files")
            files += found
        elif p.exists():
            files.append(p)
        elif "%" in item:
            found = _printf_files(item)
            if not found:
                raise NlosError(f"{item}: no files match this numbered pattern")
            files += found
        elif any(c in item for c in "*?["):
            found = [Path(f) for f in glob.glob(item)]
            if not found:
                raise NlosError(f"{item}: no files match this pattern")
            files += found
        else:
            raise NlosError(f"{item}: file not found")
    twice = [(f, n) for f, n in Counter(f.resolve() for f in files).items() if n > 1]
    if twice:
        f, n = twice[0]
        raise NlosError(f"{f}: given {n} times; give each frame once (a burst is that many different photographs)")
    return sorted(files, key=_natural_key)


def _check_finite(a: np.ndarray, source: str) -> None:
    """Finite, and still finite once cast to the network's float32 (1.7e308 is finite in float64)."""
    if not np.all(np.isfinite(a)):
        raise NlosError(f"{source}: image contains NaN or infinity")
    if a.size and float(np.abs(a).max()) > np.finfo(np.float32).max:
        raise NlosError(f"{source}: image holds values beyond float32's range (|x| > 3.4e38)")


def load_frames(items: list[str], shape: tuple[int, int], linear: bool = False,
                fps: float | None = None) -> Frames:
    """Read every input (see :func:`expand_inputs`) and resample it to ``shape`` = (H, W).

    A video must be the only input. Raises :class:`NlosError` on a missing or unreadable file,
    a wrong array shape or a non-finite value, naming the file (and frame).
    """
    if fps is not None and not (np.isfinite(fps) and fps > 0):
        raise NlosError(f"--fps: expected a positive number, got {fps}")
    files = expand_inputs(items)
    videos = [f for f in files if f.suffix.lower() in VIDEO_SUFFIXES]
    if videos and len(files) > 1:
        raise NlosError(f"{videos[0]}: a video must be the only input")
    out, sources, native, clips = [], [], set(), []
    if videos:
        frames, video_fps = read_video(videos[0], linear)
        fps = fps or video_fps
        for k, frame in enumerate(frames):
            _check_finite(frame, f"{videos[0]} frame {k}")
            native.add(frame.shape[:2])
            out.append(area_resize(frame, shape))
            clips.append(clip_flag(frame, shape))
            sources.append(f"{videos[0].name}#{k}")
        if not out:
            raise NlosError(f"{videos[0]}: the video has no frames")
    for f in files if not videos else []:
        suffix = f.suffix.lower()
        if suffix == ".npy":
            stack = read_npy(f)
            for k, img in enumerate(stack):
                _check_finite(img, f"{f} frame {k}" if len(stack) > 1 else str(f))
            native.add(stack.shape[1:3])
            out += list(area_resize(stack, shape))
            clips += [None] * len(stack)
            sources += [f"{f.name}[{k}]" for k in range(len(stack))] if len(stack) > 1 else [f.name]
        elif suffix in IMAGE_SUFFIXES:
            img = read_image(f, linear)
            native.add(img.shape[:2])
            out.append(area_resize(img, shape))
            clips.append(clip_flag(img, shape))
            sources.append(f.name)
        else:
            raise NlosError(f"{f}: unsupported input type '{f.suffix}' "
                            f"(use .npy, .png, .jpg or a video: {', '.join(VIDEO_SUFFIXES)})")
    clipped = None if all(c is None for c in clips) else \
        np.stack([np.zeros(shape, bool) if c is None else c for c in clips])
    return Frames(np.stack(out).astype(np.float32), sources, fps, sorted(native), clipped)


def clip_flag(image: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """(H0, W0, 3) values in [0, 1] (linear or not: 1 is the file's largest code) -> (H, W) bool, True
    where any pixel under the output pixel's footprint has a channel at 1 (what the camera clipped)."""
    sat = (np.asarray(image) >= 1.0).any(axis=-1).astype(np.float64)[..., None]
    return area_resize(sat, shape)[..., 0] > 1e-9
