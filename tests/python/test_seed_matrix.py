"""scripts/seed-matrix: seed lists, and one short run of a scenario for two seeds through mfot-inprocess and
mfot-evaluate (the seeds reach capture.seed and tracker.seed, so the two runs differ). Needs the build
(MFOT_BINARY_DIR or build/); skipped with the reason without it."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

SOURCE_DIR = Path(os.environ.get("MFOT_SOURCE_DIR", Path(__file__).resolve().parents[2]))
BUILD_DIR = Path(os.environ.get("MFOT_BINARY_DIR", SOURCE_DIR / "build"))
SCRIPT = SOURCE_DIR / "scripts" / "seed-matrix"
sys.path.insert(0, str(SOURCE_DIR / "scripts"))
from mfot_script_module import load_script  # noqa: E402


class SeedMatrixTest(unittest.TestCase):
    def test_seed_lists(self):
        try:
            module = load_script(SCRIPT, "seed_matrix")
        except ModuleNotFoundError as e:  # python3-yaml missing from this interpreter
            self.skipTest(str(e))
        self.assertEqual(module.parse_seeds("1-3"), [1, 2, 3])
        self.assertEqual(module.parse_seeds("2,7,9-10"), [2, 7, 9, 10])

    def test_two_seeds_give_two_different_runs(self):
        if not (BUILD_DIR / "services" / "inprocess" / "mfot-inprocess").is_file():
            self.skipTest(f"no build in {BUILD_DIR}")
        with tempfile.TemporaryDirectory() as tmp:
            result = subprocess.run([sys.executable, str(SCRIPT), "--scenarios", "static", "--seeds", "1,2",
                                     "--max-frames", "12", "--jobs", "2", "--out", tmp, "--json",
                                     "--build-dir", str(BUILD_DIR)], capture_output=True, text=True, timeout=170)
            if result.returncode != 0 and "No module named 'yaml'" in result.stderr:
                self.skipTest("python3-yaml missing from this interpreter")
            self.assertEqual(result.returncode, 0, result.stderr)
            rows = json.loads(result.stdout)
            self.assertEqual([(r["scenario"], r["seed"]) for r in rows], [("static", 1), ("static", 2)])
            for r in rows:
                self.assertGreater(r["segmentation"], 0.5)
                self.assertGreater(r["objects"], 0)
                config = (Path(tmp) / f"static-seed{r['seed']}" / "config.yaml").read_text()
                self.assertIn(f"seed: {r['seed']}", config)
            poses = [(Path(tmp) / f"static-seed{s}" / "run" / "poses.csv").read_text() for s in (1, 2)]
            roc = (Path(tmp) / "confidence_roc.csv").read_text().splitlines()
            self.assertEqual(roc[0], "scenario,threshold,wrong_below,right_below")
            self.assertEqual(len(roc), 1 + 2 * 21)  # static and all, 21 thresholds each
            self.assertNotEqual(poses[0], poses[1])  # other sensor noise and filter draws

    def test_a_refused_config_stops_the_matrix_with_the_services_reason(self):
        if not (BUILD_DIR / "services" / "inprocess" / "mfot-inprocess").is_file():
            self.skipTest(f"no build in {BUILD_DIR}")
        with tempfile.TemporaryDirectory() as tmp:
            config = Path(tmp) / "bad.yaml"
            config.write_text("tracker:\n  particles: 0\n")
            result = subprocess.run([sys.executable, str(SCRIPT), "--scenarios", "static,stack", "--seeds", "1-3",
                                     "--max-frames", "5", "--jobs", "2", "--config", str(config), "--out", tmp,
                                     "--build-dir", str(BUILD_DIR)], capture_output=True, text=True, timeout=170)
            if result.returncode != 0 and "No module named 'yaml'" in result.stderr:
                self.skipTest("python3-yaml missing from this interpreter")
            self.assertNotEqual(result.returncode, 0)
            self.assertIn("configuration refused: tracker.particles", result.stderr)
            self.assertNotIn("Traceback", result.stderr)


class RocTest(unittest.TestCase):
    def setUp(self):
        try:
            self.module = load_script(SCRIPT, "seed_matrix")
        except ModuleNotFoundError as e:
            self.skipTest(str(e))

    def test_unestimated_frames_are_the_ground_truth_frames_no_estimate_was_compared_in(self):
        objects = [{"groundtruth_first_frame": 0, "groundtruth_last_frame": 99, "compared_frames": 100},
                   {"groundtruth_first_frame": 10, "groundtruth_last_frame": 59, "compared_frames": 35}]
        self.assertEqual(self.module.unestimated_frames(objects), 15)
        self.assertEqual(self.module.unestimated_frames(objects[:1]), 0)

    def test_segmentation_losses_are_the_largest_shares_given_to_the_wrong_object(self):
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "run_segments.csv"
            path.write_text(
                "groundtruth_id,predicted_id,mapped_groundtruth_id,points,share_of_points,share_of_groundtruth,frames\n"
                "0,5,101,40,0.002,1,3\n"      # background given to the hand's id
                "1,2,1,9000,0.45,0.9,100\n"   # right
                "1,3,4,800,0.04,0.08,100\n"   # a seam: object 1's points under object 4's id
                "1,0,0,200,0.01,0.02,20\n"    # left unlabelled
                "4,3,4,9000,0.45,1,100\n"     # right
                "101,7,-1,100,0.005,0.1,4\n")  # a hand's piece under an unmatched id
            losses = self.module.segmentation_losses(path)
            self.assertEqual([(x["groundtruth_id"], x["predicted_id"]) for x in losses], [(1, 3), (1, 0), (101, 7)])
            self.assertEqual(self.module.describe_loss(losses[0]), "object 1 to object 4's id: 4.00 % of the scene points, in 100 frames")
            self.assertEqual(self.module.describe_loss(losses[1]), "object 1 to no object: 1.00 % of the scene points, in 20 frames")
            self.assertEqual(self.module.describe_loss(losses[2]), "object 101 to an unmatched id: 0.50 % of the scene points, in 4 frames")
            self.assertEqual(len(self.module.segmentation_losses(path, count=10)), 4)

    def test_object_errors_take_the_worst_objects_median_and_a_cans_observable_rotation(self):
        def obj(median, maximum, symmetric=False, frames=10, observable=(0.0, 0.0)):
            return {"symmetric": symmetric, "pose_error": {
                "frames": frames, "rotation_median_deg": median, "rotation_max_deg": maximum,
                "observable_rotation_median_deg": observable[0], "observable_rotation_max_deg": observable[1],
                "translation_median_mm": 1.0, "translation_max_mm": 2.0}}
        e = self.module.object_errors([obj(2.4, 11.0), obj(0.5, 3.0), obj(9.0, 40.0, symmetric=True, observable=(0.6, 4.0)),
                                       obj(50.0, 90.0, frames=0)])
        self.assertEqual(e["rotation_worst_median_deg"], 2.4)  # not the median of medians (0.6)
        self.assertEqual(e["rotation_median_deg"], 0.6)
        self.assertEqual(e["rotation_max_deg"], 11.0)  # the can's 40 deg about its axis and the uncompared one left out
        self.assertEqual(self.module.object_errors([])["rotation_worst_median_deg"], 0.0)

    def test_procedural_report_groups_runs_by_motion_mover_and_shape_and_judges_the_targets(self):
        def run(seed, motion, seg, objects):
            return {"seed": seed, "segmentation": seg,
                    "scene": {"motion": motion, "mover": "none",
                              "objects": [{"id": i + 1, "shape": o[0], "moved": i == 0} for i, o in enumerate(objects)]},
                    "per_object": [{"id": i + 1, "estimated": o[4], "rot_median": o[1], "rot_max": o[2],
                                    "trans_median": o[3]} for i, o in enumerate(objects)]}
        good_box, bad_can = ("box", 0.5, 3.0, 1.0, True), ("can", 5.0, 40.0, 1.0, True)
        lost_mug = ("mug", 0.1, 0.2, 0.1, False)
        rows = [run(1, "spin", 0.995, [bad_can, good_box]), run(2, "slide", 0.999, [good_box]),
                run(3, "slide", 0.98, [good_box, lost_mug])]
        measures = self.module.run_measures(rows[0])
        self.assertEqual(measures, {"segmentation": True, "rotation": False, "translation": True, "no_frame_over": False})
        self.assertTrue(self.module.run_measures(rows[0], {2})["rotation"])  # the box alone
        self.assertFalse(self.module.run_measures(rows[2])["translation"])  # a lost object fails every pose measure
        lines = self.module.procedural_report(rows)
        self.assertIn("| spin | 1 | 100 % | 0 % | 100 % | 0 % |", lines)
        self.assertIn("| slide | 2 | 50 % | 50 % | 50 % | 50 % |", lines)
        self.assertIn("| tumble | 0 | 0 % | 0 % | 0 % | 0 % |", lines)  # every motion class listed
        self.assertIn("| box | 3 | 67 % | 100 % | 100 % | 100 % |", lines)
        self.assertIn("| can | 1 | 100 % | 0 % | 100 % | 0 % |", lines)
        self.assertTrue(any(line.startswith("- every motion class listed: FAIL") for line in lines))
        self.assertEqual(lines[-1], "targets: FAIL (0 of 5 met)")
        self.assertTrue(any("3 development seeds" in line for line in lines))

    def test_a_run_stopped_at_the_timeout_fails_every_measure_in_its_classes(self):
        with tempfile.TemporaryDirectory() as tmp:
            truth = Path(tmp) / "run" / "groundtruth"
            truth.mkdir(parents=True)
            (truth / "scene.yaml").write_text("motion: spin\nmover: hand\nobjects:\n  - {id: 1, shape: can, moved: true}\n"
                                              "  - {id: 2, shape: box}\n")
            row = self.module.unfinished_run("procedural", 1001, Path(tmp), 300)
        self.assertEqual(row["lost"], 2)
        self.assertEqual(self.module.run_measures(row), {"segmentation": False, "rotation": False,
                                                          "translation": False, "no_frame_over": False})
        lines = self.module.procedural_report([row])
        self.assertIn("| spin | 1 | 0 % | 0 % | 0 % | 0 % |", lines)
        self.assertIn("| can | 1 | 0 % | 0 % | 0 % | 0 % |", lines)
        self.assertTrue(any("1 acceptance seeds" in line for line in lines))

    def test_confidence_pairs_join_poses_and_errors_with_the_threshold_given(self):
        with tempfile.TemporaryDirectory() as tmp:
            run = Path(tmp)
            (run / "run").mkdir()
            (run / "eval").mkdir()
            (run / "run" / "poses.csv").write_text(
                "frame,utime,object_id,x,y,z,qx,qy,qz,qw,confidence,stale\n"
                "0,0,1,0,0,1,0,0,0,1,0.9,0\n0,0,2,0,0,1,0,0,0,1,0.2,0\n1,0,1,0,0,1,0,0,0,1,0.4,0\n")
            (run / "eval" / "run_pose_errors.csv").write_text(
                "frame,groundtruth_id,predicted_id,translation_mm,rotation_deg,observable_rotation_deg\n"
                "0,1,1,1,2,2\n0,101,2,1,30,30\n1,1,1,1,7,7\n2,1,1,1,20,20\n")
            files = (run / "run" / "poses.csv", run / "eval" / "run_pose_errors.csv")
            pairs = self.module.confidence_pairs(*files, {101})  # the hand and the frame without a pose left out
            self.assertEqual(pairs, [(0.9, False), (0.4, False)])
            self.assertEqual(self.module.confidence_pairs(*files, {101}, 5.0), [(0.9, False), (0.4, True)])

    def test_auc_of_a_perfect_a_useless_and_an_inverted_confidence(self):
        auc = self.module.roc_auc
        self.assertEqual(auc([(0.1, True), (0.2, True), (0.8, False), (0.9, False)]), 1.0)
        self.assertEqual(auc([(0.5, True), (0.5, False)]), 0.5)
        self.assertEqual(auc([(0.9, True), (0.1, False)]), 0.0)
        self.assertAlmostEqual(auc([(0.1, True), (0.6, True), (0.5, False), (0.9, False)]), 0.75)
        self.assertIsNone(auc([(0.3, False)]))

    def test_roc_points_are_the_shares_below_each_threshold(self):
        points = self.module.roc_points([(0.1, True), (0.6, True), (0.5, False), (0.9, False)], steps=4)
        self.assertEqual([t for t, _, _ in points], [0.0, 0.25, 0.5, 0.75, 1.0])
        self.assertEqual(points[1], (0.25, 0.5, 0.0))   # one wrong frame below 0.25, no right one
        self.assertEqual(points[3], (0.75, 1.0, 0.5))
        self.assertEqual(points[4], (1.0, 1.0, 1.0))

    def test_roc_plot_is_drawn(self):
        try:
            import matplotlib  # noqa: F401
        except ImportError:
            self.skipTest("python3-matplotlib missing from this interpreter")
        pairs = [(0.1, True), (0.6, True), (0.5, False), (0.9, False)]
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "roc.png"
            self.assertTrue(self.module.plot_roc({"all": self.module.roc_points(pairs)},
                                                 {"all": self.module.roc_auc(pairs)}, path))
            self.assertEqual(path.read_bytes()[:8], b"\x89PNG\r\n\x1a\n")


if __name__ == "__main__":
    unittest.main()
