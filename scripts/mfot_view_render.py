"""What scripts/mfot-view draws, as pure functions of decoded messages (no LCM, no display).

    render(frame, scene, segmentation, poses, rate_hz) -> PIL.Image (RGB)

takes the generated LCM types' objects of one frame (frame_t, and where known its scene_cloud_t,
segmentation_t and poses_t) and draws:
  - the colour image (frame_t colour: raw RGB, JPEG or PNG);
  - every segmented scene point blended with its object's colour (object_colour(id), the same for an
    id in every frame), as a square of the point's voxel size projected at its depth, nearest point
    on top; pixels of no labelled point are left as they are;
  - each posed object's id at its projected origin, with its flags: "stale" (object_pose_t.stale:
    the tracker missed this frame) and "hidden" (the object has a pose but no scene point of this
    frame's segmentation carries its id);
  - each posed object's axes, AXIS_LENGTH_M long: x red, y green, z blue, projected with the
    frame's fx, fy, cx, cy;
  - a header: frame number, the measured rate, objects and how many are stale / hidden.

FrameAssembler collects the four channels' messages by frame number and hands out a frame's
bundle once all four are there (or when a newer frame is complete, too many are open, or it is too
old); RateMeter measures a rate over a sliding window. mfot-view and the tests use these as they are.
Needs python3-pil and python3-numpy.
"""

from __future__ import annotations

import colorsys
import io
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np
from PIL import Image, ImageDraw, ImageFont

AXIS_LENGTH_M = 0.05
AXIS_COLOURS = ((255, 0, 0), (0, 255, 0), (0, 0, 255))  # x, y, z
OVERLAY_ALPHA = 0.5
# A projected voxel is drawn at most this many pixels either side of its pixel.
MAX_SPLAT_HALF = 6

COLOR_RAW, COLOR_JPEG, COLOR_PNG = 0, 1, 2


class RenderError(ValueError):
    """A message that cannot be drawn (colour that does not decode or disagrees with its header)."""


def object_colour(object_id: int) -> Tuple[int, int, int]:
    """A bright colour for an object id, the same in every frame and run (golden-ratio hues)."""
    hue = (object_id * 0.618033988749895) % 1.0
    r, g, b = colorsys.hsv_to_rgb(hue, 0.85, 1.0)
    return int(round(255 * r)), int(round(255 * g)), int(round(255 * b))


def blend(pixel: Sequence[int], colour: Sequence[int], alpha: float = OVERLAY_ALPHA) -> Tuple[int, int, int]:
    """What the overlay makes of `pixel` under `colour` (as render() computes it, rounded)."""
    return tuple(int(np.floor((1.0 - alpha) * p + alpha * c + 0.5)) for p, c in zip(pixel, colour))


def decode_colour(frame) -> Image.Image:
    """The frame's colour image as an RGB PIL image; RenderError when it does not decode or its size
    disagrees with frame.width x frame.height."""
    width, height = int(frame.width), int(frame.height)
    if width <= 0 or height <= 0:
        raise RenderError(f"frame {frame.seq}: image size {width}x{height}")
    data = bytes(frame.color_data)
    if frame.color_encoding == COLOR_RAW:
        if len(data) != width * height * 3:
            raise RenderError(f"frame {frame.seq}: raw colour of {len(data)} bytes, expected {width * height * 3}")
        return Image.frombytes("RGB", (width, height), data)
    if frame.color_encoding not in (COLOR_JPEG, COLOR_PNG):
        raise RenderError(f"frame {frame.seq}: unknown colour encoding {frame.color_encoding}")
    try:
        with Image.open(io.BytesIO(data)) as image:
            image.load()
            rgb = image.convert("RGB")
    except (OSError, SyntaxError, ValueError) as e:
        raise RenderError(f"frame {frame.seq}: colour does not decode ({e})") from None
    if rgb.size != (width, height):
        raise RenderError(f"frame {frame.seq}: colour image is {rgb.size[0]}x{rgb.size[1]}, header says {width}x{height}")
    return rgb


def quaternion_matrix(w: float, x: float, y: float, z: float) -> np.ndarray:
    """Rotation matrix of a (not necessarily unit) quaternion w, x, y, z; identity for a zero one."""
    n = math.sqrt(w * w + x * x + y * y + z * z)
    if n == 0.0 or not math.isfinite(n):
        return np.eye(3)
    w, x, y, z = w / n, x / n, y / n, z / n
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


@dataclass(frozen=True)
class Intrinsics:
    fx: float
    fy: float
    cx: float
    cy: float

    def project(self, point: Sequence[float]) -> Optional[Tuple[float, float]]:
        """Pixel (u, v) of a camera-frame point; None behind or too near the camera."""
        x, y, z = (float(c) for c in point)
        if not (z > 1e-3 and math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
            return None
        return self.fx * x / z + self.cx, self.fy * y / z + self.cy


def intrinsics_of(frame, scene=None) -> Optional[Intrinsics]:
    for source in (frame, scene):
        if source is not None and source.fx > 0 and source.fy > 0:
            return Intrinsics(float(source.fx), float(source.fy), float(source.cx), float(source.cy))
    return None


def label_image(scene, segmentation, width: int, height: int, intrinsics: Optional[Intrinsics]) -> np.ndarray:
    """int32 height x width: each labelled scene point's object id over its pixel and the square its
    voxel covers at its depth (nearest point wins where squares overlap), 0 elsewhere."""
    labels = np.zeros((height, width), dtype=np.int32)
    n = int(scene.num_points)
    if n == 0:
        return labels
    label = np.asarray(segmentation.label[:n], dtype=np.int32)
    keep = label != 0
    if not keep.any():
        return labels
    u = np.asarray(scene.u[:n], dtype=np.int64)[keep]
    v = np.asarray(scene.v[:n], dtype=np.int64)[keep]
    z = np.asarray(scene.z[:n], dtype=np.float64)[keep]
    label = label[keep]
    fx = intrinsics.fx if intrinsics else 0.0
    voxel = float(scene.voxel_size)
    with np.errstate(divide="ignore", invalid="ignore"):
        half = np.where(z > 1e-3, np.floor(0.5 * voxel * fx / z), 0.0)
    half = np.clip(np.nan_to_num(half, nan=0.0, posinf=0.0), 0, MAX_SPLAT_HALF).astype(np.int64)
    pixels, depths, ids = [], [], []
    for h in np.unique(half):
        chosen = half == h
        cu, cv, cz, cl = u[chosen], v[chosen], z[chosen], label[chosen]
        for dv in range(-h, h + 1):
            for du in range(-h, h + 1):
                pu, pv = cu + du, cv + dv
                inside = (pu >= 0) & (pu < width) & (pv >= 0) & (pv < height)
                # The point's own pixel before any neighbour's square: distance 0 sorts first at equal depth.
                pixels.append(pv[inside] * width + pu[inside])
                depths.append(cz[inside] + 1e-9 * max(abs(du), abs(dv)))
                ids.append(cl[inside])
    pixel = np.concatenate(pixels)
    if pixel.size == 0:
        return labels
    depth = np.concatenate(depths)
    ident = np.concatenate(ids)
    order = np.lexsort((depth, pixel))
    pixel, ident = pixel[order], ident[order]
    first = np.ones(pixel.size, dtype=bool)
    first[1:] = pixel[1:] != pixel[:-1]
    labels.reshape(-1)[pixel[first]] = ident[first]
    return labels


def segmentation_matches(scene, segmentation) -> bool:
    return (scene is not None and segmentation is not None and int(segmentation.frame_seq) == int(scene.frame_seq)
            and int(segmentation.num_points) == int(scene.num_points))


_FONT_CACHE: Dict[int, Any] = {}


def font(size: int):
    """DejaVu Sans (fonts-dejavu-core) at `size` pixels, else PIL's built-in bitmap font."""
    if size not in _FONT_CACHE:
        try:
            _FONT_CACHE[size] = ImageFont.truetype("DejaVuSans.ttf", size)
        except OSError:
            path = Path("/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf")
            try:
                _FONT_CACHE[size] = ImageFont.truetype(str(path), size)
            except OSError:
                _FONT_CACHE[size] = ImageFont.load_default()
    return _FONT_CACHE[size]


def _text_box(draw: ImageDraw.ImageDraw, xy: Tuple[float, float], text: str, fnt, fill, background) -> None:
    left, top, right, bottom = draw.textbbox(xy, text, font=fnt)
    draw.rectangle((left - 2, top - 1, right + 2, bottom + 1), fill=background)
    draw.text(xy, text, font=fnt, fill=fill)


@dataclass
class ObjectFlags:
    id: int
    stale: bool
    hidden: Optional[bool]  # None: no segmentation of this frame to tell


def object_flags(poses, segmentation_ids: Optional[set]) -> List[ObjectFlags]:
    flags = []
    for obj in (poses.objects[:poses.num_objects] if poses is not None else []):
        hidden = None if segmentation_ids is None else obj.id not in segmentation_ids
        flags.append(ObjectFlags(int(obj.id), bool(obj.stale), hidden))
    return flags


def render(frame, scene=None, segmentation=None, poses=None, rate_hz: Optional[float] = None,
           alpha: float = OVERLAY_ALPHA, axis_length: float = AXIS_LENGTH_M,
           image: Optional[Image.Image] = None) -> Image.Image:
    """The frame's colour image with the label overlay, ids, flags, pose axes and header (see the
    module's docstring). `image` is the decoded colour if the caller has it already. Messages of
    another frame than `frame` (by seq) are left out; a segmentation that does not fit its scene is
    left out and said in the header."""
    base = (image if image is not None else decode_colour(frame)).convert("RGB")
    width, height = base.size
    seq = int(frame.seq)
    notes = []
    if scene is not None and int(scene.frame_seq) != seq:
        scene = None
    if segmentation is not None and int(segmentation.frame_seq) != seq:
        segmentation = None
    if poses is not None and int(poses.frame_seq) != seq:
        poses = None
    intrinsics = intrinsics_of(frame, scene)

    segmentation_ids = None
    pixels = np.asarray(base, dtype=np.float64)
    if scene is not None and segmentation is not None:
        if segmentation_matches(scene, segmentation):
            labels = label_image(scene, segmentation, width, height, intrinsics)
            segmentation_ids = set(int(i) for i in np.unique(np.asarray(segmentation.label, dtype=np.int64))) - {0}
            ids = np.unique(labels)
            for object_id in ids[ids != 0]:
                mask = labels == object_id
                pixels[mask] = (1.0 - alpha) * pixels[mask] + alpha * np.asarray(object_colour(int(object_id)), dtype=np.float64)
        else:
            notes.append(f"segmentation of {segmentation.num_points} points does not fit the scene's {scene.num_points}")
    out = Image.fromarray(np.floor(pixels + 0.5).clip(0, 255).astype(np.uint8), "RGB")
    draw = ImageDraw.Draw(out)
    text_size = max(10, height // 40)
    fnt = font(text_size)

    flags = object_flags(poses, segmentation_ids)
    if poses is not None and intrinsics is None:
        notes.append("no intrinsics: poses not drawn")
    if poses is not None and intrinsics is not None:
        # Ids and flags first, axes on top, so an axis is never hidden under a label.
        axes = []
        for obj, flag in zip(poses.objects[:poses.num_objects], flags):
            origin = np.asarray(obj.position[:3], dtype=np.float64)
            o = intrinsics.project(origin)
            if o is None or not (-width <= o[0] <= 2 * width and -height <= o[1] <= 2 * height):
                continue
            text = f"{flag.id}" + (" stale" if flag.stale else "") + (" hidden" if flag.hidden else "")
            colour = object_colour(flag.id)
            luminance = 0.299 * colour[0] + 0.587 * colour[1] + 0.114 * colour[2]
            # Above-left of the origin, where it covers as little of the axes' start as possible.
            left, top, right, bottom = draw.textbbox((0, 0), text, font=fnt)
            _text_box(draw, (o[0] - (right - left) - 6, o[1] - (bottom - top) - 8), text, fnt,
                      (0, 0, 0) if luminance > 140 else (255, 255, 255), colour)
            rotation = quaternion_matrix(*obj.orientation[:4])
            for k in range(3):
                end = intrinsics.project(origin + axis_length * rotation[:, k])
                if end is not None:
                    axes.append(((o[0], o[1]), end, AXIS_COLOURS[k]))
        line_width = max(2, height // 240)
        for start, end, colour in axes:
            draw.line((start, end), fill=colour, width=line_width)

    header = [f"frame {seq}"]
    header.append(f"{rate_hz:.1f} frames/s" if rate_hz is not None and math.isfinite(rate_hz) else "– frames/s")
    if poses is not None:
        stale = sum(f.stale for f in flags)
        hidden = sum(bool(f.hidden) for f in flags)
        header.append(f"{len(flags)} objects" + (f", {stale} stale" if stale else "") +
                      (f", {hidden} hidden" if hidden else ""))
    else:
        header.append("no poses")
    if scene is None:
        header.append("no scene")
    elif segmentation is None:
        header.append("no segmentation")
    _text_box(draw, (6, 4), "   ".join(header + notes), fnt, (255, 255, 255), (0, 0, 0))
    return out


# ---- collecting a frame's messages -----------------------------------------------------------


KINDS = ("frame", "scene", "segmentation", "poses")


@dataclass
class Bundle:
    """One frame's messages as far as they came; rate_hz is the frame rate measured when it came."""
    seq: int
    frame: Any = None
    scene: Any = None
    segmentation: Any = None
    poses: Any = None
    rate_hz: Optional[float] = None
    t: float = 0.0  # when its first message came (seconds, the caller's clock)

    def complete(self) -> bool:
        return all(getattr(self, k) is not None for k in KINDS)

    def render(self, **kwargs) -> Image.Image:
        return render(self.frame, self.scene, self.segmentation, self.poses, self.rate_hz, **kwargs)


@dataclass
class FrameAssembler:
    """Collects messages by frame number. add() returns the bundles it releases, oldest first:
    a frame's once its frame, scene, segmentation and poses are all there, with every older one
    (as far as it came); the oldest when more than max_pending are open; expire(t) those older than
    max_age_s; flush() the rest. Bundles without a frame_t are dropped (counted in `dropped`), as are
    messages of a frame already released (`late`)."""
    max_pending: int = 8
    max_age_s: Optional[float] = None
    pending: Dict[int, Bundle] = field(default_factory=dict)
    released_up_to: int = -1
    dropped: int = 0
    late: int = 0

    def add(self, kind: str, seq: int, message, t: float = 0.0, rate_hz: Optional[float] = None) -> List[Bundle]:
        if kind not in KINDS:
            raise ValueError(f"unknown kind {kind}")
        seq = int(seq)
        if seq <= self.released_up_to:
            self.late += 1
            return []
        bundle = self.pending.get(seq)
        if bundle is None:
            bundle = self.pending[seq] = Bundle(seq, t=t)
        setattr(bundle, kind, message)
        if kind == "frame":
            bundle.rate_hz = rate_hz
        if bundle.complete():
            return self._release(lambda s: s <= seq)
        if len(self.pending) > self.max_pending:
            oldest = min(self.pending)
            return self._release(lambda s: s <= oldest)
        return []

    def expire(self, t: float) -> List[Bundle]:
        if self.max_age_s is None:
            return []
        old = [s for s, b in self.pending.items() if t - b.t > self.max_age_s]
        if not old:
            return []
        newest = max(old)
        return self._release(lambda s: s <= newest)

    def flush(self) -> List[Bundle]:
        return self._release(lambda s: True)

    def _release(self, chosen) -> List[Bundle]:
        out = []
        for seq in sorted(s for s in self.pending if chosen(s)):
            bundle = self.pending.pop(seq)
            self.released_up_to = max(self.released_up_to, seq)
            if bundle.frame is None:
                self.dropped += 1
            else:
                out.append(bundle)
        return out


class RateMeter:
    """Events per second over the last `window` events (None until two came)."""

    def __init__(self, window: int = 30):
        self.times: List[float] = []
        self.window = window

    def add(self, t: float) -> Optional[float]:
        self.times.append(t)
        if len(self.times) > self.window:
            del self.times[0]
        return self.rate()

    def rate(self) -> Optional[float]:
        if len(self.times) < 2 or self.times[-1] <= self.times[0]:
            return None
        return (len(self.times) - 1) / (self.times[-1] - self.times[0])
