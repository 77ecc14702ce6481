#!/usr/bin/env python3
"""The process group over two simulated hosts (network namespaces on a bridge, LCM with ttl=1):
host-a runs the whole group with 4 tracker workers, host-b only 2 tracker workers (mfot-run --role
workers). The 3 objects of a `random` scene are spread over both hosts; when every process of host-b
is killed at once, its objects go to host-a's idle workers with their ids, and every frame still
gets its poses."""

from __future__ import annotations

import json
import os
import sys
import tempfile
import time
import unittest
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "scripts"))
import mfot_lcm  # noqa: E402
import mfot_netns  # noqa: E402

BUILD = Path(os.environ.get("MFOT_BUILD_DIR", REPO / "build")).resolve()
URL = "udpm://239.255.76.67:7720?ttl=1"
FRAMES = 240
WORKER_TIMEOUT_S = 1.0  # merger.worker_timeout_ms of configs/default.yaml


def poses_frames(run: Path) -> int:
    """Frames in the merger's poses.csv so far (it is flushed before every publish)."""
    path = run / "poses.csv"
    if not path.is_file():
        return 0
    lines = path.read_text().splitlines()[1:]
    return len({line.split(",", 1)[0] for line in lines if line})


class TwoHostsTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        ok, why = mfot_netns.available()
        if not ok:
            raise unittest.SkipTest(why)
        cls.types = mfot_lcm.load_types(os.environ.get("MFOT_LCM_PY_DIR") or str(BUILD / "lcmtypes/python"))

    def test_objects_spread_and_survive_the_loss_of_a_host(self):
        with tempfile.TemporaryDirectory() as tmp, mfot_netns.SimulatedHosts(["host-a", "host-b"]) as hosts:
            tmp = Path(tmp)
            env = dict(os.environ, MFOT_LCM_URL=URL, PYTHONUNBUFFERED="1")
            run_a, run_b = tmp / "a", tmp / "b"
            workers = hosts.start("host-b", [sys.executable, str(REPO / "scripts/mfot-run"), "--role", "workers",
                                             "--workers", "2", "--build-dir", str(BUILD), "--out", str(run_b),
                                             "--backend", "cpu", "--quiet"], tmp / "b.log", env=env, cwd=REPO)
            deadline = time.monotonic() + 30
            while not (run_b / "processes.json").is_file() and time.monotonic() < deadline:
                time.sleep(0.1)
            group = hosts.start("host-a", [sys.executable, str(REPO / "scripts/mfot-run"), "--scenario", "random",
                                           "--max-frames", str(FRAMES), "--workers", "4", "--expect-workers", "6", "--build-dir", str(BUILD),
                                           "--out", str(run_a), "--backend", "cpu", "--quiet"], tmp / "a.log",
                                env=env, cwd=REPO)
            # Host b is lost a third of the way through.
            deadline = time.monotonic() + 300
            while poses_frames(run_a) < FRAMES // 3 and group.poll() is None and time.monotonic() < deadline:
                time.sleep(0.05)
            self.assertIsNone(group.poll(), (tmp / "a.log").read_text()[-3000:])
            self.assertIsNone(workers.poll(), (tmp / "b.log").read_text()[-3000:])
            killed_at_us = time.time() * 1e6
            hosts.kill("host-b")
            group.wait(600)
            log_a = (tmp / "a.log").read_text()
            self.assertEqual(group.returncode, 0, log_a[-3000:])

            host_b_ids = {int(name[len("tracker"):]) for name in
                          json.loads((run_b / "processes.json").read_text())["workers"]}
            owner_before, owner_after, moved_at, history = {}, {}, {}, {}
            poses_frames_seen, ids_before, ids_after = set(), set(), set()
            for ev in mfot_lcm.read_log(run_a / "mfot.lcmlog"):
                if ev.channel.startswith("MFOT_MODEL_"):
                    m = self.types.object_model_t.decode(ev.data)
                    history.setdefault(m.object_id, []).append((round((ev.utime - killed_at_us) / 1e6, 3), m.worker_id))
                    if m.worker_id < 0:
                        continue
                    if ev.utime < killed_at_us:
                        owner_before[m.object_id] = m.worker_id
                    else:
                        owner_after[m.object_id] = m.worker_id
                        if m.worker_id not in host_b_ids:
                            moved_at.setdefault(m.object_id, ev.utime)
                elif ev.channel == "MFOT_POSES":
                    p = self.types.poses_t.decode(ev.data)
                    poses_frames_seen.add(p.frame_seq)
                    (ids_before if ev.utime < killed_at_us else ids_after).update(o.id for o in p.objects)

            self.assertEqual(poses_frames_seen, set(range(FRAMES)), "every frame gets poses")
            on_b = {obj for obj, worker in owner_before.items() if worker in host_b_ids}
            self.assertTrue(on_b, f"no object was tracked on host-b (owners {owner_before}, host-b {host_b_ids})")
            self.assertTrue(any(w not in host_b_ids for w in owner_before.values()), "host-a tracked nothing")
            for obj in on_b:
                self.assertIn(obj, owner_after, f"object {obj} of host-b never reassigned")
                self.assertNotIn(owner_after[obj], host_b_ids,
                                 f"object {obj} still owned by host-b after its loss: {history[obj][-30:]}")
                self.assertLess((moved_at[obj] - killed_at_us) / 1e6, WORKER_TIMEOUT_S + 0.5,
                                f"object {obj} reassigned too late")
            self.assertTrue(ids_before <= ids_after, f"ids lost with the host: {ids_before - ids_after}")
            hosts_json = json.loads((run_a / "workers.json").read_text())
            self.assertIn("host-b", hosts_json.values(), hosts_json)


if __name__ == "__main__":
    unittest.main()
