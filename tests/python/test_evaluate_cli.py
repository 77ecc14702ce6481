"""mfot-evaluate's command line (exit codes, messages, summary.json) and scripts/mfot-plot."""

import importlib.util
import json
import os
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

SOURCE_DIR = Path(os.environ.get("MFOT_SOURCE_DIR", Path(__file__).resolve().parents[2]))
EVALUATE = os.environ.get("MFOT_EVALUATE")

GT_HEADER = "frame,utime,object_id,is_hand,x,y,z,qx,qy,qz,qw\n"
RUN_HEADER = "frame,utime,object_id,x,y,z,qx,qy,qz,qw,confidence,stale\n"


@unittest.skipUnless(EVALUATE, "MFOT_EVALUATE (mfot-evaluate binary) not given")
class EvaluateCliTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.addCleanup(self.tmp.cleanup)
        self.root = Path(self.tmp.name)
        for d in ("gt/labels", "run/labels"):
            (self.root / d).mkdir(parents=True)
        (self.root / "gt/poses.csv").write_text(GT_HEADER + "0,0,1,0,0,0,1,0,0,0,1\n1,1,1,0,0.01,0,1,0,0,0,1\n")
        (self.root / "run/fitting.csv").write_text("frame,object_id,fitting_distance_m\n0,1,0.004\n1,1,0.002\n")

    def evaluate(self, *extra):
        command = [EVALUATE, "--groundtruth", str(self.root / "gt"), "--run", f"m1={self.root / 'run'}",
                   "--out", str(self.root / "out"), "--no-plots", *extra]
        return subprocess.run(command, capture_output=True, text=True, timeout=60)

    def test_malformed_line_exits_1_naming_file_and_line(self):
        (self.root / "run/poses.csv").write_text(RUN_HEADER + "0,0,1,0,0,1,0,0,0,1,0.9,0\n1,1,1,0,0,1,0,0,0\n")
        result = self.evaluate()
        self.assertEqual(result.returncode, 1)
        self.assertIn(f"{self.root / 'run/poses.csv'}:3: expected 12 fields, got 9", result.stderr)

    def test_missing_file_exits_1_naming_it(self):
        result = self.evaluate()
        self.assertEqual(result.returncode, 1)
        self.assertIn(f"{self.root / 'run/poses.csv'}: cannot open file", result.stderr)

    def test_summary_json_holds_the_numbers(self):
        (self.root / "run/poses.csv").write_text(RUN_HEADER + "0,0,1,0,0,1,0,0,0,1,0.9,0\n1,1,1,0,0,1,0,0,0,1,0.9,0\n")
        result = self.evaluate()
        self.assertEqual(result.returncode, 0, result.stderr)
        self.assertIn("m1", result.stdout)
        summary = json.loads((self.root / "out/summary.json").read_text())
        [run] = summary["runs"]
        self.assertEqual(run["name"], "m1")
        self.assertAlmostEqual(run["fitting_distance_mean_m"], 0.003)
        self.assertEqual(run["segmentation"]["frames"], 0)
        plots = json.loads((self.root / "out/plots.json").read_text())
        self.assertEqual(plots["fitting"]["runs"][0]["name"], "m1")

    def test_bad_arguments_exit_nonzero(self):
        self.assertEqual(self.evaluate("--translation-threshold-mm", "0").returncode, 2)
        result = subprocess.run([EVALUATE, "--groundtruth", str(self.root / "gt"), "--run", "a/b=x",
                                 "--out", str(self.root / "out")], capture_output=True, text=True, timeout=60)
        self.assertEqual(result.returncode, 1)
        self.assertIn("run name 'a/b'", result.stderr)

    @unittest.skipUnless(importlib.util.find_spec("matplotlib"), "matplotlib not installed for this python3")
    def test_plot_script_draws_the_figures(self):
        (self.root / "run/poses.csv").write_text(RUN_HEADER + "0,0,1,0,0,1,0,0,0,1,0.9,0\n1,1,1,0,0,1,0,0,0,1,0.9,0\n")
        self.assertEqual(self.evaluate().returncode, 0)
        plot = subprocess.run([sys.executable, str(SOURCE_DIR / "scripts/mfot-plot"), str(self.root / "out/plots.json")],
                              capture_output=True, text=True, timeout=120)
        self.assertEqual(plot.returncode, 0, plot.stderr)
        for name in ("fitting_distance.png", "pose_error_m1.png"):
            self.assertTrue((self.root / "out" / name).read_bytes().startswith(b"\x89PNG"), name)


if __name__ == "__main__":
    unittest.main()
