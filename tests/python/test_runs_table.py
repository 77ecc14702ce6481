"""scripts/runs-table: a row per run from its summary.json, a clear error for a run without one, and with
--stages each stage's time a frame from the run's log (a log written here with known receive times)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "scripts"))
import mfot_lcm  # noqa: E402

SCRIPT = REPO / "scripts" / "runs-table"


def summary(fps: float, merger_ms: float) -> dict:
    return {"mean_fps": fps, "log_fps": fps + 1, "latency_ms_p50": 20.0, "latency_ms_p99": 40.0, "frames": 100,
            "frames_lost": 0, "cores_busy": 1.5, "problems": [],
            "cpu_ms_per_frame": {"capture": 10.0, "preprocess": 5.0, "tracker0": 2.0, "tracker1": 3.0,
                                 "merger": merger_ms},
            "evaluation": {"segmentation": {"points": 10, "accuracy": 0.995}}}


class RunsTableTest(unittest.TestCase):
    def setUp(self):
        self.tmp = Path(tempfile.mkdtemp(prefix="mfot_runs_table_"))

    def tearDown(self):
        subprocess.run(["rm", "-rf", str(self.tmp)], check=False)

    def run_table(self, *args: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True, timeout=60)

    def test_a_row_per_run_with_its_figures(self):
        for name, fps, merger in (("a", 25.5, 18.25), ("b", 30.25, 9.5)):
            (self.tmp / name).mkdir()
            (self.tmp / name / "summary.json").write_text(json.dumps(summary(fps, merger)))
        res = self.run_table(f"before={self.tmp / 'a'}", str(self.tmp / "b"))
        self.assertEqual(res.returncode, 0, res.stderr)
        rows = [line for line in res.stdout.splitlines() if line.startswith("| ") and "---" not in line][1:]
        self.assertEqual(len(rows), 2)
        self.assertTrue(rows[0].startswith("| before | 25.50 | 26.50 | 20.0 / 40.0 | 10.0 / 5.0 | 5.0 | 18.2"), rows[0])
        self.assertTrue(rows[1].startswith("| b | 30.25 |"), rows[1])
        self.assertIn("99.50 %", rows[1])

    def test_a_run_without_a_summary_is_named(self):
        res = self.run_table(str(self.tmp / "missing"))
        self.assertEqual(res.returncode, 1)
        self.assertIn(str(self.tmp / "missing" / "summary.json"), res.stderr)

    def test_stage_times_from_the_log(self):
        types_dir = os.environ.get("MFOT_LCM_PY_DIR")
        try:
            types = mfot_lcm.load_types(types_dir)
        except mfot_lcm.LcmError as e:
            self.skipTest(str(e))
        run = self.tmp / "run"
        run.mkdir()
        (run / "summary.json").write_text(json.dumps(summary(30.0, 5.0)))
        events = []
        for seq in range(60):  # a frame every 20 ms; scene 7 ms after it, estimates at 9 and 12, poses at 15
            t0 = 1_000_000 + 20_000 * seq
            frame = types.frame_t()
            frame.seq = seq
            frame.depth_data = frame.color_data = b""
            scene = types.scene_cloud_t()
            scene.frame_seq = seq
            scene.r = scene.g = scene.b = b""
            poses = types.poses_t()
            poses.frame_seq = seq
            events.append((t0, "MFOT_FRAME", frame.encode()))
            events.append((t0 + 7_000, "MFOT_SCENE", scene.encode()))
            for dt in (9_000, 12_000):
                estimate = types.tracker_estimate_t()
                estimate.frame_seq = seq
                estimate.orientation = [1.0, 0.0, 0.0, 0.0]
                events.append((t0 + dt, "MFOT_ESTIMATE", estimate.encode()))
            events.append((t0 + 15_000, "MFOT_POSES", poses.encode()))
        mfot_lcm.write_log(run / "mfot.lcmlog", events)
        args = ["--stages"] + (["--types-dir", types_dir] if types_dir else []) + [f"r={run}"]
        res = self.run_table(*args)
        self.assertEqual(res.returncode, 0, res.stderr)
        stages = [line for line in res.stdout.splitlines() if line.startswith("| r |")][-1]
        self.assertEqual(stages, "| r | 20.0 / 20.0 / 20.0 | 7.0 / 7.0 / 7.0 | 2.0 / 2.0 / 2.0 | 3.0 / 3.0 / 3.0 | "
                                 "3.0 / 3.0 / 3.0 |")


if __name__ == "__main__":
    unittest.main()
