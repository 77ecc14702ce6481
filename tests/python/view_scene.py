"""A small synthetic frame for the mfot-view tests, built with the generated LCM types: a 320x240
gradient image, scene points with known pixels and labels, and poses whose axes are easy to find.

    object 3: labelled points at (100..104, 150) and one near point (z 0.3 m, a 3x3 square) at (60, 200);
              posed at POSE_3 (all three axes visible)
    object 5: labelled points at (240..242, 80); posed, stale
    object 7: posed, no labelled point (hidden)
    label 0:  a scene point at (200, 200), unlabelled
"""

from __future__ import annotations

import io
import math

WIDTH, HEIGHT = 320, 240
FX = FY = 300.0
CX, CY = 160.0, 120.0
VOXEL = 0.005
# 60 degrees about (1, 1, 0)/sqrt(2): no axis points along the viewing ray.
_HALF = math.radians(60.0) / 2
POSE_3 = ((0.02, 0.0, 0.6), (math.cos(_HALF), math.sin(_HALF) / math.sqrt(2), math.sin(_HALF) / math.sqrt(2), 0.0))
POSE_5 = ((0.3, -0.2, 0.9), (1.0, 0.0, 0.0, 0.0))
POSE_7 = ((-0.3, -0.2, 0.9), (1.0, 0.0, 0.0, 0.0))

POINTS_3 = [(u, 150, 0.8) for u in range(100, 105)]
NEAR_POINT_3 = (60, 200, 0.3)  # 0.5 * 5 mm * 300 px / 0.3 m = 2.5 px: a square 2 px either side
POINTS_5 = [(u, 80, 0.9) for u in range(240, 243)]
UNLABELLED = (200, 200, 0.8)
EMPTY_PIXEL = (300, 230)  # no point near it


def base_rgb(u: int, v: int, seq: int = 0):
    """The colour image's pixel (a gradient, different in each frame)."""
    return ((u * 7 + seq * 13) % 256, (v * 5 + 40) % 256, (u + v + 90) % 256)


def image_bytes(seq: int = 0) -> bytes:
    return bytes(c for v in range(HEIGHT) for u in range(WIDTH) for c in base_rgb(u, v, seq))


def back_project(u: int, v: int, z: float):
    return ((u - CX) * z / FX, (v - CY) * z / FY, z)


def make_frame(types, seq: int = 0, encoding: str = "raw"):
    frame = types.frame_t()
    frame.utime = frame.capture_utime = 1_000_000 + seq * 33_333
    frame.seq = seq
    frame.source = "test:view"
    frame.width, frame.height = WIDTH, HEIGHT
    frame.fx, frame.fy, frame.cx, frame.cy = FX, FY, CX, CY
    frame.depth_encoding = types.frame_t.DEPTH_RAW
    frame.depth_data = bytes(WIDTH * HEIGHT * 2)
    frame.depth_size = len(frame.depth_data)
    raw = image_bytes(seq)
    if encoding == "raw":
        frame.color_encoding, data = types.frame_t.COLOR_RAW, raw
    else:
        from PIL import Image

        buf = io.BytesIO()
        Image.frombytes("RGB", (WIDTH, HEIGHT), raw).save(buf, format="PNG")
        frame.color_encoding, data = types.frame_t.COLOR_PNG, buf.getvalue()
    frame.color_data = data
    frame.color_size = len(data)
    return frame


def labelled_points():
    """(u, v, z, label) of every scene point."""
    return ([(u, v, z, 3) for u, v, z in POINTS_3] + [(*NEAR_POINT_3, 3)] + [(u, v, z, 5) for u, v, z in POINTS_5]
            + [(*UNLABELLED, 0)])


def make_scene(types, seq: int = 0):
    scene = types.scene_cloud_t()
    scene.utime = scene.capture_utime = 1_000_000 + seq * 33_333
    scene.frame_seq = seq
    scene.width, scene.height = WIDTH, HEIGHT
    scene.fx, scene.fy, scene.cx, scene.cy = FX, FY, CX, CY
    scene.voxel_size = VOXEL
    scene.plane = [0.0, -1.0, 0.0, 0.5]
    points = labelled_points()
    scene.num_points = len(points)
    xyz = [back_project(u, v, z) for u, v, z, _ in points]
    scene.x, scene.y, scene.z = ([p[k] for p in xyz] for k in range(3))
    scene.r = bytes(128 for _ in points)
    scene.g = bytes(128 for _ in points)
    scene.b = bytes(128 for _ in points)
    scene.u = [u for u, _, _, _ in points]
    scene.v = [v for _, v, _, _ in points]
    scene.cluster = [0 for _ in points]
    scene.num_clusters = 1
    return scene


def make_segmentation(types, seq: int = 0):
    seg = types.segmentation_t()
    seg.utime = 1_000_000 + seq * 33_333
    seg.frame_seq = seq
    seg.label = [label for _, _, _, label in labelled_points()]
    seg.num_points = len(seg.label)
    return seg


def make_poses(types, seq: int = 0):
    poses = types.poses_t()
    poses.utime = poses.capture_utime = 1_000_000 + seq * 33_333
    poses.frame_seq = seq
    for object_id, (position, orientation), stale in ((3, POSE_3, False), (5, POSE_5, True), (7, POSE_7, False)):
        o = types.object_pose_t()
        o.id = object_id
        o.position = list(position)
        o.orientation = list(orientation)
        o.world_position = list(position)
        o.world_orientation = list(orientation)
        o.confidence = 0.9
        o.stale = stale
        poses.objects.append(o)
    poses.num_objects = len(poses.objects)
    return poses


def project(point):
    x, y, z = point
    return FX * x / z + CX, FY * y / z + CY


def axis_ends(position, orientation, length: float = 0.05):
    """Projected origin and the ends of the x, y, z axes."""
    w, x, y, z = orientation
    r = [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
         [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
         [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]]
    ends = [project([position[i] + length * r[i][k] for i in range(3)]) for k in range(3)]
    return project(position), ends


def write_log(types, path, frames: int = 3, encoding: str = "png", extra=()):
    """An LCM log of `frames` frames in the order the group publishes (frame, scene, poses,
    segmentation), with a status message between; returns the event count."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "scripts"))
    import mfot_lcm

    events = []
    for seq in range(frames):
        t = 1_000_000 + seq * 33_333
        status = types.service_status_t()
        status.service = "capture"
        events += [(t, "MFOT_FRAME", make_frame(types, seq, encoding).encode()),
                   (t + 100, "MFOT_STATUS", status.encode()),
                   (t + 5000, "MFOT_SCENE", make_scene(types, seq).encode()),
                   (t + 9000, "MFOT_POSES", make_poses(types, seq).encode()),
                   (t + 9500, "MFOT_SEGMENTATION", make_segmentation(types, seq).encode())]
    events += list(extra)
    return mfot_lcm.write_log(path, events)
