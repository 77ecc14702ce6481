"""mfot-labels on a keyed group's log read long after it was recorded: the group's authenticated messages are
drawn whatever their age (a log has no live clock to compare with), a forged frame is not; a cut log names its
byte offset and exits 1; a foreign file is not an LCM log."""

from __future__ import annotations

import os
import struct
import subprocess
import sys
import tempfile
import time
import unittest
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "scripts"))
import mfot_auth  # noqa: E402
import mfot_lcm  # noqa: E402

BUILD = Path(os.environ.get("MFOT_BINARY_DIR", REPO / "build"))
LABELS = BUILD / "services" / "labels" / "mfot-labels"
W, H, F = 8, 6, 8.0
GROUP = 7


class MfotLabelsTest(unittest.TestCase):
    def setUp(self):
        if not LABELS.is_file():
            self.skipTest(f"{LABELS} is not built")
        try:
            self.types = mfot_lcm.load_types(os.environ.get("MFOT_LCM_PY_DIR"))
        except mfot_lcm.LcmError as e:
            self.skipTest(str(e))
        self.run_dir = Path(tempfile.mkdtemp(prefix="mfot_labels_"))
        key = self.run_dir / "group.key"
        key.write_bytes(bytes(range(40)))
        key.chmod(0o600)
        (self.run_dir / "config.yaml").write_text(
            f"group:\n  id: {GROUP}\n  key_file: {key}\n  max_message_age_s: 30\n")
        self.ours = mfot_auth.Authenticator(GROUP, bytes(range(40)), sender=11)
        self.forger = mfot_auth.Authenticator(GROUP, bytes(range(1, 41)), sender=12)

    def tearDown(self):
        subprocess.run(["rm", "-rf", str(self.run_dir)], check=False)

    def messages(self, seq: int, utime: int, stamp) -> list[tuple[int, str, bytes]]:
        """A frame whose centre pixel is 0.5 m away, its one scene point there, labelled 3."""
        t = self.types
        frame = t.frame_t()
        frame.utime, frame.seq, frame.source = utime, seq, "test"
        frame.width, frame.height, frame.fx, frame.fy, frame.cx, frame.cy = W, H, F, F, W / 2, H / 2
        frame.depth_encoding, frame.color_encoding = frame.DEPTH_RAW, frame.COLOR_RAW
        frame.depth_data = struct.pack(f"<{W * H}H", *([500] * (W * H)))
        frame.depth_size = len(frame.depth_data)
        frame.color_data = bytes(3 * W * H)
        frame.color_size = len(frame.color_data)
        scene = t.scene_cloud_t()
        scene.utime, scene.frame_seq = utime, seq
        scene.width, scene.height, scene.fx, scene.fy, scene.cx, scene.cy = W, H, F, F, W / 2, H / 2
        scene.voxel_size, scene.voxel_origin, scene.plane = 0.005, [-1.0, -1.0, 0.0], [0.0, 0.0, 0.0, 0.0]
        scene.num_points = 1
        scene.x, scene.y, scene.z = [0.0002], [0.0002], [0.5]
        scene.r = scene.g = scene.b = b"\x80"
        scene.u, scene.v, scene.cluster, scene.num_clusters = [W // 2], [H // 2], [0], 1
        segmentation = t.segmentation_t()
        segmentation.utime, segmentation.frame_seq, segmentation.num_points, segmentation.label = utime, seq, 1, [3]
        return [(utime, "MFOT_FRAME", stamp.stamp(frame.encode())), (utime, "MFOT_SCENE", stamp.stamp(scene.encode())),
                (utime, "MFOT_SEGMENTATION", stamp.stamp(segmentation.encode()))]

    def draw(self) -> subprocess.CompletedProcess:
        return subprocess.run([str(LABELS), "--run", str(self.run_dir)], capture_output=True, text=True, timeout=60)

    def test_an_old_keyed_log_is_drawn_and_a_forged_frame_is_not(self):
        an_hour_ago = int((time.time() - 3600) * 1e6)
        events = self.messages(1, an_hour_ago, self.ours) + self.messages(2, an_hour_ago + 1000, self.forger)
        mfot_lcm.write_log(self.run_dir / "mfot.lcmlog", events)
        res = self.draw()
        self.assertEqual(res.returncode, 0, res.stdout + res.stderr)
        self.assertIn("1 label images", res.stdout)
        self.assertIn("messages not drawn: 0 of other groups, 3 forged, 0 replayed", res.stdout)
        self.assertTrue((self.run_dir / "labels" / "000001.png").is_file())
        self.assertFalse((self.run_dir / "labels" / "000002.png").exists())

    def test_a_cut_log_names_the_byte_and_fails(self):
        now = int(time.time() * 1e6)
        mfot_lcm.write_log(self.run_dir / "mfot.lcmlog", self.messages(1, now, self.ours) + self.messages(2, now, self.ours))
        whole = (self.run_dir / "mfot.lcmlog").read_bytes()
        (self.run_dir / "mfot.lcmlog").write_bytes(whole[:-10])
        res = self.draw()
        self.assertEqual(res.returncode, 1, res.stdout + res.stderr)
        self.assertRegex(res.stdout + res.stderr, r"at byte \d+")
        self.assertTrue((self.run_dir / "labels" / "000001.png").is_file())  # the frame before the cut

    def test_a_foreign_file_is_not_an_lcm_log(self):
        (self.run_dir / "mfot.lcmlog").write_bytes(b"\x7fELF" + bytes(100))
        res = self.draw()
        self.assertEqual(res.returncode, 1)
        self.assertIn("not an LCM log", res.stdout + res.stderr)


if __name__ == "__main__":
    unittest.main()
