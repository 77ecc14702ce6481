"""Object discovery on real Kinect/Xtion table tops: the mOSD learn scenes in tests/data/mosd (stacked,
touching and occluded objects) through scripts/bench-mosd (mfot's preprocessing and first-frame objects with
the default config). The learn-split figures of docs/results.md are guarded here: every ground-truth object found
(IoU >= 0.5), at most 0.2 spurious objects per scene, and at most 1 % of the objects' points above the table
left in no object."""

import json
import os
import subprocess
import sys
import unittest
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
SCENES = REPO / "tests" / "data" / "mosd"


class RealScenesTest(unittest.TestCase):
    def test_discovery_finds_the_objects_of_real_scenes(self):
        env = dict(os.environ)
        cmd = [sys.executable, str(REPO / "scripts" / "bench-mosd"), str(SCENES), "--no-pcl", "--json"]
        if env.get("MFOT_BUILD_DIR"):
            cmd += ["--build-dir", env["MFOT_BUILD_DIR"]]
        result = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
        self.assertEqual(result.returncode, 0, result.stderr)
        table = json.loads(result.stdout)
        everything = table["mfot"]["all"]
        self.assertEqual(everything["scenes"], 4)
        self.assertEqual(everything["segments"], 13)
        self.assertGreaterEqual(everything["found"], 0.95, everything)
        self.assertGreaterEqual(everything["wov"], 0.93, everything)
        self.assertLessEqual(everything["spurious_per_scene"], 0.2, everything)
        self.assertLessEqual(everything["unassigned"], 0.01, everything)


if __name__ == "__main__":
    unittest.main()
