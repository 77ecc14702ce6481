#!/usr/bin/env python3
"""The process group (scripts/mfot-run in lockstep over LCM) and mfot-inprocess (the same objects wired by direct
calls) give byte-identical outputs: poses, fitting distances and label images. mfot-inprocess re-implements the
merger-to-tracker wiring; this is what keeps the two the same method."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("MFOT_BUILD_DIR", REPO / "build"))
# `contact`: a hand pushes a box against another, so the merger's segmentation, model update and assignment all
# feed back into the trackers within these frames.
SCENARIO, FRAMES, PORT = "contact", 90, 7711


def run(cmd: list[str], env: dict | None = None) -> None:
    res = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=900, cwd=REPO)
    if res.returncode != 0:
        raise AssertionError(f"{cmd[0]} failed ({res.returncode}):\n{res.stdout[-4000:]}\n{res.stderr[-4000:]}")


class GroupVsInprocessTest(unittest.TestCase):
    def test_group_and_inprocess_give_identical_outputs(self):
        with tempfile.TemporaryDirectory() as tmp:
            group, inprocess = Path(tmp) / "group", Path(tmp) / "inprocess"
            env = dict(os.environ, MFOT_LCM_URL=f"udpm://239.255.76.67:{PORT}?ttl=0")
            run([sys.executable, str(REPO / "scripts/mfot-run"), "--build-dir", str(BUILD), "--out", str(group),
                 "--quiet", "--backend", "cpu", "--scenario", SCENARIO, "--max-frames", str(FRAMES)], env)
            run([str(BUILD / "services/inprocess/mfot-inprocess"), "--scenario", SCENARIO, "--backend", "cpu",
                 "--max-frames", str(FRAMES), "--out", str(inprocess)])
            poses = (group / "poses.csv").read_bytes()
            self.assertEqual(len(poses.splitlines()), len((inprocess / "poses.csv").read_bytes().splitlines()))
            self.assertGreater(len(poses.splitlines()), FRAMES, "every frame has poses")
            for name in ("poses.csv", "fitting.csv"):
                self.assertEqual((group / name).read_bytes(), (inprocess / name).read_bytes(), name)
            labels = sorted(p.name for p in (group / "labels").iterdir())
            self.assertEqual(len(labels), FRAMES)
            self.assertEqual(labels, sorted(p.name for p in (inprocess / "labels").iterdir()))
            for name in labels:
                self.assertEqual((group / "labels" / name).read_bytes(), (inprocess / "labels" / name).read_bytes(),
                                 f"labels/{name}")


if __name__ == "__main__":
    unittest.main(verbosity=2)
