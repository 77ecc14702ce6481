"""scripts/soak's RSS slope: least squares over the samples after the warm-up, in MB/min (flagged over
the limit, issue 55: 0.1 MB/min) and in MB per 1000 frames; its id churn against the ground truth."""

from __future__ import annotations

import csv
import sys
import tempfile
import unittest
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "scripts"))
from mfot_script_module import load_script  # noqa: E402

soak = load_script(REPO / "scripts" / "soak", "soak")


class RssSlopeTest(unittest.TestCase):
    def test_growth_after_the_warm_up_is_measured_and_flagged(self):
        rows = []
        for t in range(0, 180, 5):
            # The merger grows 2.7 MB/min after a start-up jump; the tracker settles; capture wobbles. 20 frames/s.
            frames = 20 * t
            rows.append((float(t), "merger", 50.0 + (20.0 if t >= 30 else 0.0) + 2.7 * t / 60.0, frames))
            rows.append((float(t), "tracker0", 30.0 + (8.0 if t < 60 else 0.0), frames))
            rows.append((float(t), "capture", 40.0 + (0.5 if (t // 5) % 2 else -0.5), frames))
        slopes = soak.rss_slopes(rows, warmup_s=60.0, limit=soak.RSS_SLOPE_LIMIT_MB_PER_MIN)
        self.assertAlmostEqual(slopes["merger"]["rss_slope_mb_per_min"], 2.7, places=3)
        self.assertTrue(slopes["merger"]["grows"])
        # 2.7 MB/min at 1200 frames/min: 2.25 MB per 1000 frames.
        self.assertAlmostEqual(slopes["merger"]["rss_slope_mb_per_1000_frames"], 2.25, places=3)
        self.assertEqual(slopes["tracker0"]["rss_slope_mb_per_min"], 0.0)  # the drop before the warm-up is left out
        self.assertFalse(slopes["tracker0"]["grows"])
        self.assertLess(abs(slopes["capture"]["rss_slope_mb_per_min"]), 0.1)
        self.assertFalse(slopes["capture"]["grows"])
        self.assertEqual(slopes["merger"]["rss_mb_peak"], round(70.0 + 2.7 * 175 / 60.0, 1))

    def test_too_few_samples_give_no_slope_and_no_flag(self):
        slopes = soak.rss_slopes([(70.0, "preprocess", 10.0, 100), (75.0, "preprocess", 90.0, 200)], 60.0, 0.1)
        self.assertIsNone(slopes["preprocess"]["rss_slope_mb_per_min"])
        self.assertIsNone(slopes["preprocess"]["rss_slope_mb_per_1000_frames"])
        self.assertFalse(slopes["preprocess"]["grows"])


def write_csv(path: Path, header: list[str], rows: list[list]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)


class IdChurnTest(unittest.TestCase):
    def test_ids_are_told_apart_by_the_body_they_follow(self):
        # Object 1 stays at x = -0.2; object 2 sits at x = 0.2 and slides +x from frame 40 while hand 101 hovers in
        # front of it (on its line of sight, nearer the camera); hand 102 passes far off. The tracker follows object
        # 1 as id 1 throughout; object 2 as id 2, lost at frame 45 and found again as id 4 from frame 50; id 3
        # follows hand 102; id 5 is a ghost at x = 1. Warm-up ends at frame 30.
        with tempfile.TemporaryDirectory() as tmp:
            run = Path(tmp)
            truth, poses = [], []
            for f in range(100):
                x2 = 0.2 + (0.005 * (f - 40) if f >= 40 else 0.0)
                truth += [[f, 0, 1, 0, -0.2, 0.0, 1.0], [f, 0, 2, 0, x2, 0.0, 1.0],
                          [f, 0, 101, 1, 0.12, 0.0, 0.6], [f, 0, 102, 1, -0.2, 0.5, 0.5]]
                poses.append([f, 0, 1, -0.2, 0.0, 1.02])
                if f <= 45:
                    poses.append([f, 0, 2, min(x2, 0.21), 0.0, 1.02])
                if f >= 50:
                    poses.append([f, 0, 4, x2, 0.0, 1.02])
                if 20 <= f < 40:
                    poses.append([f, 0, 3, -0.2, 0.45, 0.5])
                if f >= 60:
                    poses.append([f, 0, 5, 1.0, 0.0, 1.0])
            write_csv(run / "groundtruth" / "poses.csv", ["frame", "utime", "object_id", "is_hand", "x", "y", "z"],
                      truth)
            write_csv(run / "poses.csv", ["frame", "utime", "object_id", "x", "y", "z"], poses)
            churn = soak.id_churn(run, warmup_frame=30, match_m=0.10)
        self.assertEqual(churn["ids"], 5)
        self.assertEqual(churn["ids_per_object"], {"1": [1], "2": [2, 4]})
        self.assertEqual(churn["rebirths"], 1)
        self.assertEqual(churn["ids_on_hands"], [3])
        self.assertEqual(churn["ids_unmatched"], [5])
        self.assertEqual(churn["new_ids_after_warmup"], [4, 5])
        self.assertEqual(churn["rebirths_hand_in_front"], 1)
        self.assertEqual(churn["rebirths_sliding"], 1)
        [rebirth] = churn["rebirth_details"]
        self.assertEqual((rebirth["object"], rebirth["old_id"], rebirth["new_id"], rebirth["frame"]), (2, 2, 4, 50))
        self.assertAlmostEqual(rebirth["speed_m_s"], 0.15, places=3)  # 5 mm a frame at 30 frames/s

    def test_labels_match_an_id_to_the_body_it_covers_not_the_nearest_origin(self):
        # Hand 101 reaches in above object 1: its id 2 is born from its fingertips, whose centroid (the id's origin)
        # lies 3 cm from object 1's origin and 20 cm from the palm's. By position id 2 is a second id of object 1; by
        # its labelled points (mfot-evaluate's segments table) it is the hand's.
        with tempfile.TemporaryDirectory() as tmp:
            run = Path(tmp)
            truth, poses = [], []
            for f in range(60):
                truth += [[f, 0, 1, 0, 0.0, 0.0, 1.0], [f, 0, 101, 1, 0.0, -0.2, 0.8]]
                poses.append([f, 0, 1, 0.0, 0.0, 1.0])
                if f >= 20:
                    poses.append([f, 0, 2, 0.0, -0.03, 0.99])
            write_csv(run / "groundtruth" / "poses.csv", ["frame", "utime", "object_id", "is_hand", "x", "y", "z"],
                      truth)
            write_csv(run / "poses.csv", ["frame", "utime", "object_id", "x", "y", "z"], poses)
            segments = run / "eval" / "run_segments.csv"
            write_csv(segments, ["groundtruth_id", "predicted_id", "mapped_groundtruth_id", "points", "share_of_points",
                                 "share_of_groundtruth", "frames"],
                      [[0, 2, 101, 40, 0.001, 0.0, 10], [1, 1, 1, 9000, 0.6, 0.99, 60], [1, 2, 101, 30, 0.002, 0.01, 5],
                       [101, 2, 101, 4000, 0.3, 0.97, 40], [101, 1, 1, 90, 0.01, 0.02, 8]])
            by_position = soak.id_churn(run, warmup_frame=0, match_m=0.10)
            by_labels = soak.id_churn(run, warmup_frame=0, match_m=0.10, segments=segments)
        self.assertEqual(by_position["matched_by"], "position")
        self.assertEqual(by_position["ids_per_object"], {"1": [1, 2]})
        self.assertEqual(by_position["rebirths"], 1)
        self.assertEqual(by_labels["matched_by"], "labels")
        self.assertEqual(by_labels["ids_per_object"], {"1": [1]})
        self.assertEqual(by_labels["rebirths"], 0)
        self.assertEqual(by_labels["ids_on_hands"], [2])

    def test_no_ground_truth_no_churn(self):
        with tempfile.TemporaryDirectory() as tmp:
            self.assertIsNone(soak.id_churn(Path(tmp), warmup_frame=0, match_m=0.10))


if __name__ == "__main__":
    unittest.main()
