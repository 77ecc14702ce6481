"""scripts/mfot-view: its drawing (scripts/mfot_view_render.py) on a synthetic frame built with the
generated LCM types, judged by pixel content, and the command on a log written with mfot_lcm.write_log
(--png, --video, a run folder, and its errors). Needs python3-pil and python3-numpy (Debian's
/usr/bin/python3); skipped with the reason otherwise."""

from __future__ import annotations

import os
import random
import shutil
import subprocess
import sys
import tempfile
import time
import unittest
from pathlib import Path

HERE = Path(__file__).resolve().parent
SOURCE_DIR = Path(os.environ.get("MFOT_SOURCE_DIR", HERE.parents[1]))
SCRIPTS = SOURCE_DIR / "scripts"
sys.path.insert(0, str(SCRIPTS))
sys.path.insert(0, str(HERE))
import mfot_lcm  # noqa: E402
import view_scene as vs  # noqa: E402

try:
    import numpy  # noqa: F401
    from PIL import Image

    import mfot_view_render as mvr
    MISSING = None
except ImportError as e:  # the script needs them too
    MISSING = f"needs python3-pil and python3-numpy in {sys.executable} ({e}); run with /usr/bin/python3"

VIEW = SCRIPTS / "mfot-view"


def load_types(test):
    try:
        return mfot_lcm.load_types(os.environ.get("MFOT_LCM_PY_DIR"))
    except mfot_lcm.LcmError as e:
        test.skipTest(str(e))


def near(image, u: float, v: float, colour, radius: int = 1) -> bool:
    """Whether a pixel within `radius` of (u, v) has exactly `colour`."""
    cu, cv = int(round(u)), int(round(v))
    return any(image.getpixel((cu + du, cv + dv)) == tuple(colour)
               for du in range(-radius, radius + 1) for dv in range(-radius, radius + 1))


def along(start, end, share: float):
    return start[0] + share * (end[0] - start[0]), start[1] + share * (end[1] - start[1])


def check_drawing(test: unittest.TestCase, image, seq: int = 0, origin=(0, 0)) -> None:
    """The content test (a) asserts, on an image that may lie at `origin` within a larger one."""
    ox, oy = origin

    def px(u, v):
        return image.getpixel((ox + u, oy + v))

    for u, v, _ in vs.POINTS_3:
        test.assertEqual(px(u, v), mvr.blend(vs.base_rgb(u, v, seq), mvr.object_colour(3)), f"object 3 at {u},{v}")
    for u, v, _ in vs.POINTS_5:
        test.assertEqual(px(u, v), mvr.blend(vs.base_rgb(u, v, seq), mvr.object_colour(5)), f"object 5 at {u},{v}")
    # The near point's voxel covers 2 pixels either side of its own; 3 pixels away is untouched.
    nu, nv, _ = vs.NEAR_POINT_3
    for du, dv in ((0, 0), (2, 2), (-2, 1)):
        test.assertEqual(px(nu + du, nv + dv), mvr.blend(vs.base_rgb(nu + du, nv + dv, seq), mvr.object_colour(3)))
    test.assertEqual(px(nu + 3, nv), vs.base_rgb(nu + 3, nv, seq))
    # Unlabelled scene point, and a pixel of no point: the image as it came.
    uu, uv, _ = vs.UNLABELLED
    test.assertEqual(px(uu, uv), vs.base_rgb(uu, uv, seq))
    test.assertEqual(px(*vs.EMPTY_PIXEL), vs.base_rgb(*vs.EMPTY_PIXEL, seq))
    # Axes of object 3: x red, y green, z blue along their projected segments.
    start, ends = vs.axis_ends(*vs.POSE_3)
    for end, colour in zip(ends, mvr.AXIS_COLOURS):
        for share in (0.5, 0.8):
            u, v = along(start, end, share)
            test.assertTrue(near(image, ox + u, oy + v, colour), f"axis {colour} at {share} of its length: {u:.1f},{v:.1f}")


@unittest.skipIf(MISSING, MISSING)
class RenderTest(unittest.TestCase):
    def setUp(self):
        self.types = load_types(self)

    def test_overlay_axes_and_untouched_pixels(self):
        for encoding in ("raw", "png"):
            with self.subTest(encoding=encoding):
                t = self.types
                image = mvr.render(vs.make_frame(t, 4, encoding), vs.make_scene(t, 4), vs.make_segmentation(t, 4),
                                   vs.make_poses(t, 4), rate_hz=29.5)
                self.assertEqual(image.size, (vs.WIDTH, vs.HEIGHT))
                self.assertEqual(image.mode, "RGB")
                check_drawing(self, image, seq=4)

    def test_object_colours_are_stable_and_distinct(self):
        colours = [mvr.object_colour(i) for i in range(1, 21)]
        self.assertEqual(colours, [mvr.object_colour(i) for i in range(1, 21)])
        self.assertEqual(len(set(colours)), 20)
        for c in colours:  # none of them an axis colour
            self.assertNotIn(c, mvr.AXIS_COLOURS)

    def test_stale_and_hidden_flags(self):
        t = self.types
        seg = vs.make_segmentation(t)
        flags = {f.id: f for f in mvr.object_flags(vs.make_poses(t), set(seg.label) - {0})}
        self.assertEqual({i: (f.stale, f.hidden) for i, f in flags.items()},
                         {3: (False, False), 5: (True, False), 7: (False, True)})
        # Without a segmentation nothing can be said about hidden.
        self.assertEqual([f.hidden for f in mvr.object_flags(vs.make_poses(t), None)], [None, None, None])

    def test_messages_of_another_frame_are_not_drawn(self):
        t = self.types
        plain = Image.frombytes("RGB", (vs.WIDTH, vs.HEIGHT), vs.image_bytes(1))
        image = mvr.render(vs.make_frame(t, 1), vs.make_scene(t, 2), vs.make_segmentation(t, 2), vs.make_poses(t, 2))
        u, v, _ = vs.POINTS_3[0]
        self.assertEqual(image.getpixel((u, v)), plain.getpixel((u, v)))
        start, ends = vs.axis_ends(*vs.POSE_3)
        u, v = along(start, ends[0], 0.8)
        self.assertEqual(image.getpixel((round(u), round(v))), plain.getpixel((round(u), round(v))))
        # A segmentation that does not fit its scene (point counts differ) is left out too.
        seg = vs.make_segmentation(t, 1)
        seg.label, seg.num_points = seg.label[:-1], seg.num_points - 1
        image = mvr.render(vs.make_frame(t, 1), vs.make_scene(t, 1), seg, None)
        u, v, _ = vs.POINTS_3[0]
        self.assertEqual(image.getpixel((u, v)), plain.getpixel((u, v)))

    def test_undecodable_colour_is_a_render_error(self):
        frame = vs.make_frame(self.types, 0, "png")
        frame.color_data = frame.color_data[:100]
        frame.color_size = 100
        with self.assertRaisesRegex(mvr.RenderError, "does not decode"):
            mvr.decode_colour(frame)
        frame = vs.make_frame(self.types, 0, "raw")
        frame.width = 100
        with self.assertRaisesRegex(mvr.RenderError, "raw colour"):
            mvr.decode_colour(frame)

    def test_assembler_releases_complete_frames_in_order(self):
        a = mvr.FrameAssembler(max_pending=3, max_age_s=1.0)
        self.assertEqual(a.add("frame", 0, "f0", t=0.0), [])
        self.assertEqual(a.add("frame", 1, "f1", t=0.1), [])
        for kind in ("scene", "segmentation"):
            self.assertEqual(a.add(kind, 1, kind, t=0.2), [])
        released = a.add("poses", 1, "p1", t=0.2)  # frame 1 complete: frame 0 goes with it, as far as it came
        self.assertEqual([(b.seq, b.frame, b.poses) for b in released], [(0, "f0", None), (1, "f1", "p1")])
        self.assertEqual(a.add("poses", 0, "late", t=0.3), [])
        self.assertEqual(a.late, 1)
        a.add("frame", 2, "f2", t=1.0)
        self.assertEqual(a.expire(1.5), [])
        self.assertEqual([b.seq for b in a.expire(2.1)], [2])
        a.add("poses", 3, "p3", t=3.0)  # no frame_t: dropped when released
        for seq in (4, 5, 6):
            a.add("frame", seq, f"f{seq}", t=3.0)
        self.assertEqual([b.seq for b in a.pending.values()], [4, 5, 6])
        self.assertEqual(a.dropped, 1)
        self.assertEqual([b.seq for b in a.flush()], [4, 5, 6])

    def test_rate_meter(self):
        meter = mvr.RateMeter(window=5)
        self.assertIsNone(meter.add(0.0))
        for k in range(1, 10):
            rate = meter.add(k * 0.04)
        self.assertAlmostEqual(rate, 25.0)


@unittest.skipIf(MISSING, MISSING)
class CommandTest(unittest.TestCase):
    def setUp(self):
        self.types = load_types(self)
        self.tmp = Path(tempfile.mkdtemp(prefix="mfot-view-test-"))
        self.addCleanup(shutil.rmtree, self.tmp, ignore_errors=True)
        self.env = dict(os.environ)
        self.env.pop("DISPLAY", None)

    def view(self, *args, env=None):
        return subprocess.run([sys.executable, str(VIEW), *map(str, args)], capture_output=True, text=True,
                              timeout=120, env=env or self.env)

    def test_png_per_frame_from_a_log(self):
        log = self.tmp / "mfot.lcmlog"
        vs.write_log(self.types, log, frames=3)
        out = self.tmp / "png"
        res = self.view("--log", log, "--png", out)
        self.assertEqual(res.returncode, 0, res.stdout + res.stderr)
        self.assertEqual(sorted(p.name for p in out.iterdir()), [f"frame_{s:06d}.png" for s in range(3)])
        for seq in range(3):
            with Image.open(out / f"frame_{seq:06d}.png") as image:
                check_drawing(self, image.convert("RGB"), seq=seq)
        # A run folder is read through its mfot.lcmlog.
        out2 = self.tmp / "png2"
        res = self.view(self.tmp, "--png", out2)
        self.assertEqual(res.returncode, 0, res.stdout + res.stderr)
        self.assertEqual(len(list(out2.glob("frame_*.png"))), 3)

    def test_frames_without_the_other_channels_are_still_drawn(self):
        log = self.tmp / "frames-only.lcmlog"
        mfot_lcm.write_log(log, [(k, "MFOT_FRAME", vs.make_frame(self.types, k, "png").encode()) for k in range(4)])
        out = self.tmp / "png"
        res = self.view("--log", log, "--png", out)
        self.assertEqual(res.returncode, 0, res.stdout + res.stderr)
        self.assertEqual(len(list(out.glob("frame_*.png"))), 4)
        with Image.open(out / "frame_000002.png") as image:
            u, v, _ = vs.POINTS_3[0]
            self.assertEqual(image.convert("RGB").getpixel((u, v)), vs.base_rgb(u, v, 2))

    @unittest.skipUnless(shutil.which("ffmpeg") and shutil.which("ffprobe"), "needs ffmpeg and ffprobe")
    def test_video(self):
        log = self.tmp / "mfot.lcmlog"
        vs.write_log(self.types, log, frames=5)
        video = self.tmp / "out" / "view.mp4"
        res = self.view("--log", log, "--video", video)
        self.assertEqual(res.returncode, 0, res.stdout + res.stderr)
        probe = subprocess.run(["ffprobe", "-v", "error", "-count_frames", "-select_streams", "v:0", "-show_entries",
                                "stream=codec_name,width,height,nb_read_frames", "-of", "csv=p=0", str(video)],
                               capture_output=True, text=True, timeout=60)
        self.assertEqual(probe.stdout.strip(), f"h264,{vs.WIDTH},{vs.HEIGHT},5")

    def test_live_png(self):
        url = f"udpm://239.255.76.67:{random.randint(20000, 60000)}?ttl=0"
        out = self.tmp / "live"
        viewer = subprocess.Popen([sys.executable, str(VIEW), "--png", out, "--count", "3", "--wait-s", "60"],
                                  env=dict(self.env, MFOT_LCM_URL=url, PYTHONUNBUFFERED="1"),
                                  stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        self.addCleanup(lambda: viewer.poll() is None and (viewer.kill(), viewer.wait()))
        first = viewer.stdout.readline()  # once it is subscribed
        self.assertIn("listening on", first)
        self.assertIn(url.split("//")[1].split("?")[0], first)
        bus = mfot_lcm.Lcm(url)
        self.addCleanup(bus.close)
        deadline = time.monotonic() + 60
        seq = 0
        # One frame's messages at a time, in the group's order, until the viewer has drawn three and ends.
        while viewer.poll() is None and time.monotonic() < deadline:
            bus.publish("MFOT_FRAME", vs.make_frame(self.types, seq, "png").encode())
            bus.publish("MFOT_SCENE", vs.make_scene(self.types, seq).encode())
            bus.publish("MFOT_POSES", vs.make_poses(self.types, seq).encode())
            bus.publish("MFOT_SEGMENTATION", vs.make_segmentation(self.types, seq).encode())
            seq += 1
            try:
                viewer.wait(0.5)
            except subprocess.TimeoutExpired:
                pass
        said = viewer.stdout.read()
        viewer.stdout.close()
        self.assertEqual(viewer.returncode, 0, said)
        pngs = sorted(out.glob("frame_*.png"))
        self.assertEqual(len(pngs), 3, said)
        for path in pngs:
            with Image.open(path) as image:
                check_drawing(self, image.convert("RGB"), seq=int(path.stem.split("_")[1]))

    def test_clear_errors(self):
        cases = []
        cases.append(((self.tmp / "missing.lcmlog",), "no such log file or run folder"))
        garbled = self.tmp / "garbled.lcmlog"
        garbled.write_bytes(b"this is not an lcm log at all" * 10)
        cases.append(((garbled,), "the log does not read: .*not an LCM log"))
        truncated = self.tmp / "truncated.lcmlog"
        vs.write_log(self.types, truncated, frames=1)
        truncated.write_bytes(truncated.read_bytes()[:-10])
        cases.append(((truncated,), "the log does not read: .*truncated"))
        empty = self.tmp / "empty.lcmlog"
        empty.write_bytes(b"")
        cases.append(((empty,), "is empty"))
        no_frames = self.tmp / "no-frames.lcmlog"
        mfot_lcm.write_log(no_frames, [(1, "MFOT_POSES", vs.make_poses(self.types).encode()),
                                       (2, "MFOT_SCENE", vs.make_scene(self.types).encode())])
        cases.append(((no_frames,), "holds no MFOT_FRAME"))
        (self.tmp / "run").mkdir()
        cases.append(((self.tmp / "run",), "without mfot.lcmlog"))
        for args, message in cases:
            with self.subTest(args=args):
                res = self.view("--log", *args, "--png", self.tmp / "png")
                self.assertNotEqual(res.returncode, 0)
                self.assertRegex(res.stderr, "error: .*" + message)
                self.assertNotIn("Traceback", res.stderr)
        log = self.tmp / "ok.lcmlog"
        vs.write_log(self.types, log, frames=1)
        # No display and no file output.
        res = self.view("--log", log)
        self.assertNotEqual(res.returncode, 0)
        self.assertIn("no display", res.stderr)
        # --video without ffmpeg on PATH.
        bare = self.tmp / "bin"
        bare.mkdir()
        res = self.view("--log", log, "--video", self.tmp / "v.mp4", env=dict(self.env, PATH=str(bare)))
        self.assertNotEqual(res.returncode, 0)
        self.assertIn("--video needs ffmpeg", res.stderr)


if __name__ == "__main__":
    unittest.main()
