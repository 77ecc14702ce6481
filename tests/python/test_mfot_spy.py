"""scripts/mfot-spy without a display: it builds Java classes of our lcmtypes, and LCM's Java
library (what lcm-spy runs on) decodes with them what the Python types wrote to a log."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "scripts"))
import mfot_lcm  # noqa: E402

LCM_JAR = Path("/usr/share/java/lcm.jar")


@unittest.skipUnless(LCM_JAR.is_file() and all(shutil.which(t) for t in ("java", "javac", "jar", "lcm-gen")),
                     "needs liblcm-java, a JDK and lcm-gen (scripts/setup installs them)")
class MfotSpyTest(unittest.TestCase):
    def test_java_types_decode_what_python_wrote(self):
        types = mfot_lcm.load_types(os.environ.get("MFOT_LCM_PY_DIR"))
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            res = subprocess.run([sys.executable, str(REPO / "scripts/mfot-spy"), "--build-types-only", "--build-dir",
                                  str(tmp / "build")], capture_output=True, text=True, timeout=300)
            self.assertEqual(res.returncode, 0, res.stdout + res.stderr)
            jar = tmp / "build/lcmtypes/java/mfot_types.jar"
            self.assertTrue(jar.is_file())

            hb = types.heartbeat_t()
            hb.worker_id, hb.instance, hb.host, hb.object_id, hb.last_frame_seq = 42, 7, "host-x", 3, 10
            poses = types.poses_t()
            poses.frame_seq = 11
            for object_id in (5, 6):
                p = types.object_pose_t()
                p.id = object_id
                p.orientation = [1.0, 0.0, 0.0, 0.0]
                p.world_orientation = [1.0, 0.0, 0.0, 0.0]
                poses.objects.append(p)
            poses.num_objects = 2
            estimate = types.tracker_estimate_t()
            estimate.frame_seq, estimate.object_id, estimate.num_particles = 12, 5, 100
            log = tmp / "mfot.lcmlog"
            mfot_lcm.write_log(log, [(1, "MFOT_HEARTBEAT", hb.encode()), (2, "MFOT_POSES", poses.encode()),
                                     (3, "MFOT_ESTIMATE", estimate.encode())])

            classes = tmp / "classes"
            subprocess.run(["javac", "-cp", f"{LCM_JAR}:{jar}", "-d", str(classes),
                            str(Path(__file__).with_name("DecodeLog.java"))], check=True, timeout=120)
            res = subprocess.run(["java", "-cp", f"{LCM_JAR}:{jar}:{classes}", "DecodeLog", str(log)],
                                 capture_output=True, text=True, timeout=120)
            self.assertEqual(res.returncode, 0, res.stderr)
            self.assertEqual(res.stdout.splitlines(), ["heartbeat worker 42 host host-x object 3",
                                                       "poses frame 11 objects 2 first id 5",
                                                       "estimate frame 12 object 5 particles 100"])
            # Built once: a second call finds the jar up to date.
            before = jar.stat().st_mtime
            subprocess.run([sys.executable, str(REPO / "scripts/mfot-spy"), "--build-types-only", "--build-dir",
                            str(tmp / "build")], check=True, capture_output=True, timeout=60)
            self.assertEqual(jar.stat().st_mtime, before)


if __name__ == "__main__":
    unittest.main()
