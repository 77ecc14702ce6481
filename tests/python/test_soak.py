"""scripts/soak's RSS slope: least squares over the samples after the warm-up, in MB/min, flagged over
the limit (issue 55: 0.1 MB/min)."""

from __future__ import annotations

import sys
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
            # The merger grows 2.7 MB/min after a start-up jump; the tracker settles; capture wobbles.
            rows.append((float(t), "merger", 50.0 + (20.0 if t >= 30 else 0.0) + 2.7 * t / 60.0))
            rows.append((float(t), "tracker0", 30.0 + (8.0 if t < 60 else 0.0)))
            rows.append((float(t), "capture", 40.0 + (0.5 if (t // 5) % 2 else -0.5)))
        slopes = soak.rss_slopes(rows, warmup_s=60.0, limit=soak.RSS_SLOPE_LIMIT_MB_PER_MIN)
        self.assertAlmostEqual(slopes["merger"]["rss_slope_mb_per_min"], 2.7, places=3)
        self.assertTrue(slopes["merger"]["grows"])
        self.assertEqual(slopes["tracker0"]["rss_slope_mb_per_min"], 0.0)  # the drop before the warm-up is left out
        self.assertFalse(slopes["tracker0"]["grows"])
        self.assertLess(abs(slopes["capture"]["rss_slope_mb_per_min"]), 0.1)
        self.assertFalse(slopes["capture"]["grows"])
        self.assertEqual(slopes["merger"]["rss_mb_peak"], round(70.0 + 2.7 * 175 / 60.0, 1))

    def test_too_few_samples_give_no_slope_and_no_flag(self):
        slopes = soak.rss_slopes([(70.0, "preprocess", 10.0), (75.0, "preprocess", 90.0)], 60.0, 0.1)
        self.assertIsNone(slopes["preprocess"]["rss_slope_mb_per_min"])
        self.assertFalse(slopes["preprocess"]["grows"])


if __name__ == "__main__":
    unittest.main()
