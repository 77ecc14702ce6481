#!/usr/bin/env python3
"""Process-level reliability of the process group (scripts/mfot-run) over real LCM multicast:
lost and reordered messages, a tracker killed mid-run, the merger and preprocess killed and
restarted, a source that stalls and ends. Each test runs the real services on the CPU backend
and waits on conditions with deadlines."""

from __future__ import annotations

import json
import os
import select
import signal
import subprocess
import sys
import tempfile
import threading
import time
import unittest
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "scripts"))
import mfot_lcm  # noqa: E402

BUILD = Path(os.environ.get("MFOT_BUILD_DIR", REPO / "build"))
TYPES = mfot_lcm.load_types(os.environ.get("MFOT_LCM_PY_DIR") or str(BUILD / "lcmtypes/python"))
# merger.worker_timeout_ms of configs/default.yaml, in seconds
WORKER_TIMEOUT_S = 1.0


def url(port: int) -> str:
    return f"udpm://239.255.76.67:{port}?ttl=0"


class Bus:
    """Records chosen channels of one LCM bus on a thread, each message with its arrival time
    (time.monotonic()), and lets a test wait for a condition over them with a deadline."""

    # By channel regex (LCM's): every worker's MFOT_MODEL_<id> is recorded as MFOT_MODEL_.*.
    DECODERS = {"MFOT_POSES": TYPES.poses_t, "MFOT_HEARTBEAT": TYPES.heartbeat_t, "MFOT_MODEL_.*": TYPES.object_model_t,
                "MFOT_STATUS": TYPES.service_status_t}

    def __init__(self, lcm_url: str, channels: list[str]):
        self.lcm = mfot_lcm.Lcm(lcm_url, recv_buffer_bytes=64 << 20)
        self.events: dict[str, list[tuple[float, object]]] = {c: [] for c in channels}
        self.changed = threading.Condition()
        self.closing = False
        self.explain = lambda: ""  # more about a timeout: the services' logs
        self.running = lambda: True  # whether what the test waits for can still happen
        for channel in channels:
            self.lcm.subscribe(channel, lambda _name, data, channel=channel: self._on_message(channel, data))
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _on_message(self, channel: str, data: bytes) -> None:
        message = self.DECODERS[channel].decode(data)
        with self.changed:
            self.events[channel].append((time.monotonic(), message))
            self.changed.notify_all()

    def _run(self) -> None:
        while not self.closing:
            self.lcm.handle(0.05)

    def close(self) -> None:
        self.closing = True
        self.thread.join()
        self.lcm.close()

    def wait_for(self, what: str, predicate, timeout: float):
        """Waits until predicate(events) returns something truthy; returns it, or fails the test
        naming `what` after `timeout` seconds or as soon as the process group has ended."""
        deadline = time.monotonic() + timeout
        with self.changed:
            result = None

            def check():
                nonlocal result
                result = predicate(self.events)
                return result

            # Woken by every message; at least once a second to notice a group that ended.
            while not self.changed.wait_for(check, min(1.0, max(0.0, deadline - time.monotonic()))):
                if not self.running():
                    raise AssertionError(f"the process group ended while waiting for {what}\n{self.explain()}")
                if time.monotonic() >= deadline:
                    raise AssertionError(f"timed out after {timeout:.0f} s waiting for {what}\n{self.explain()}")
            return result

    def snapshot(self, channel: str) -> list[tuple[float, object]]:
        with self.changed:
            return list(self.events[channel])


class Group:
    """scripts/mfot-run in the background."""

    def __init__(self, out: Path, lcm_url: str, *args: str):
        self.out = out
        env = dict(os.environ, MFOT_LCM_URL=lcm_url)
        cmd = [sys.executable, str(REPO / "scripts/mfot-run"), "--build-dir", str(BUILD), "--out", str(out), "--quiet",
               "--backend", "cpu", *args]
        self.stdout_path = out.parent / (out.name + ".stdout")
        self.stdout = open(self.stdout_path, "w")
        self.proc = subprocess.Popen(cmd, env=env, stdout=self.stdout, stderr=subprocess.STDOUT, cwd=REPO)

    def pids(self) -> dict[str, int]:
        path = self.out / "processes.json"
        return json.loads(path.read_text()) if path.is_file() else {}

    def kill(self, service: str) -> int:
        pid = self.pids()[service]
        os.kill(pid, signal.SIGKILL)
        return pid

    def wait(self, timeout: float) -> int:
        try:
            return self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            raise AssertionError(f"the process group did not end within {timeout:.0f} s\n{self.report()}") from None

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.stdout.close()

    def report(self) -> str:
        self.stdout.flush()
        text = "--- mfot-run\n" + self.stdout_path.read_text()[-3000:]
        for log in sorted((self.out / "logs").glob("*.log")):
            text += f"\n--- {log.name}\n" + log.read_text()[-2500:]
        return text


def logged(run_dir: Path, channel: str) -> list[tuple[int, object]]:
    """(log time in microseconds, decoded message) of one channel of the run's lcm log."""
    decoder = {"MFOT_POSES": TYPES.poses_t, "MFOT_FRAME": None}[channel]
    out = []
    for ev in mfot_lcm.read_log(run_dir / "mfot.lcmlog"):
        if ev.channel != channel:
            continue
        out.append((ev.utime, decoder.decode(ev.data) if decoder else ev.data))
    return out


def frame_seq(frame_message: bytes) -> int:
    return TYPES.frame_t.decode(frame_message).seq


def write_config(path: Path, **sections) -> Path:
    cfg = yaml.safe_load((REPO / "configs/default.yaml").read_text())
    for section, values in sections.items():
        cfg.setdefault(section, {}).update(values)
    path.write_text(yaml.safe_dump(cfg))
    return path


def poses_with_seq_at_least(seq: int):
    def check(events):
        for t, p in events["MFOT_POSES"]:
            if p.frame_seq >= seq:
                return t, p
        return None
    return check


class ReliabilityTest(unittest.TestCase):
    maxDiff = None

    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.addCleanup(self.tmp.cleanup)
        self.dir = Path(self.tmp.name)

    def start_group(self, port: int, *args: str) -> tuple[Group, Bus]:
        bus = Bus(url(port), ["MFOT_POSES", "MFOT_HEARTBEAT", "MFOT_MODEL_.*", "MFOT_STATUS"])
        self.addCleanup(bus.close)
        group = Group(self.dir / "run", url(port), *args)
        self.addCleanup(group.stop)
        bus.explain = group.report
        bus.running = lambda: group.proc.poll() is None
        self.group = group
        return group, bus

    def assertGroupOk(self, group: Group, code: int):
        self.assertEqual(code, 0, group.report())

    # 1 ------------------------------------------------------------------------------------------

    def test_lost_and_reordered_messages(self):
        """Scenes, models, estimates and heartbeats between the merger and the trackers go through
        a relay that drops 10 % of them and swaps 5 %: every frame still gets its poses, without
        waiting for the (5 s lockstep) estimate timeout, and the objects keep their ids and
        tracks."""
        frames = 100
        relay = subprocess.Popen(
            [sys.executable, str(REPO / "tests/integration/lcm_relay.py"), "--a", url(7711), "--b", url(7712),
             "--a-to-b", "MFOT_SCENE,MFOT_MODEL_.*,MFOT_FRAME_DONE", "--b-to-a", "MFOT_ESTIMATE,MFOT_HEARTBEAT,MFOT_STATUS",
             "--drop", "MFOT_SCENE=0.1", "--drop", "MFOT_MODEL_.*=0.1", "--drop", "MFOT_FRAME_DONE=0.1",
             "--drop", "MFOT_ESTIMATE=0.1",
             "--drop", "MFOT_HEARTBEAT=0.05", "--swap", "0.05", "--seed", "7"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)

        def stop_relay():
            if relay.poll() is None:
                relay.kill()
            relay.communicate()

        self.addCleanup(stop_relay)
        ready, _, _ = select.select([relay.stdout], [], [], 20)
        self.assertTrue(ready and relay.stdout.readline().strip() == "ready", "relay did not start")

        group, _ = self.start_group(7711, "--scenario", "static", "--workers", "3", "--max-frames", str(frames),
                                    "--tracker-lcm-url", url(7712))
        self.assertGroupOk(group, group.wait(240))
        relay.send_signal(signal.SIGTERM)
        out, err = relay.communicate(timeout=20)
        self.assertEqual(relay.returncode, 0, err)
        counts = json.loads(out.strip().splitlines()[-1])
        print("relay:", json.dumps(counts))
        for channel in ("MFOT_SCENE", "MFOT_FRAME_DONE", "MFOT_ESTIMATE"):  # a static scene's models seldom change
            self.assertGreaterEqual(counts[channel]["dropped"], 3, f"the relay hardly touched {channel}: {counts}")
        self.assertGreaterEqual(sum(c["swapped"] for c in counts.values()), 5, counts)

        poses = logged(group.out, "MFOT_POSES")
        seqs = [p.frame_seq for _, p in poses]
        self.assertEqual(seqs, list(range(frames)), "poses for every frame, in order\n" + group.report())
        ids = {o.id for o in poses[0][1].objects}
        self.assertEqual(len(ids), 3, "the three objects of the static scene at frame 0")
        stale = 0
        for _, p in poses:
            self.assertEqual({o.id for o in p.objects}, ids, f"frame {p.frame_seq}: objects changed")
            stale += sum(o.stale for o in p.objects)
        share = stale / (3 * frames)
        print(f"stale poses: {100 * share:.1f} %")
        self.assertLess(share, 0.3, "most poses are fresh despite the drops")
        # Lost messages are noticed from sequence numbers and heartbeats, not by the timeout.
        gaps = [(b - a) / 1e6 for (a, _), (b, _) in zip(poses, poses[1:])]
        print(f"longest time between two frames' poses: {max(gaps):.2f} s")
        self.assertLess(max(gaps), 2.5, group.report())
        evaluation = json.loads((group.out / "summary.json").read_text()).get("evaluation")
        self.assertIsNotNone(evaluation, group.report())
        self.assertEqual(evaluation["tracks_lost"], 0)
        self.assertLess(evaluation["pose_error"]["translation_median_mm"], 5.0)

    # 2 ------------------------------------------------------------------------------------------

    def test_killed_tracker_object_is_reassigned(self):
        """SIGKILL the worker tracking an object: within worker_timeout + 1 s another worker
        heartbeats with that object's id, it keeps its id and its pose, and poses keep flowing.
        mfot-run would restart the worker within the timeout (and the merger would send the
        restarted worker its object again); here it may not, so the merger must reassign."""
        frames = 130
        config = write_config(self.dir / "config.yaml", group={"max_restarts": 0})
        group, bus = self.start_group(7713, "--config", str(config), "--scenario", "static", "--workers", "4",
                                      "--max-frames", str(frames))
        # An object and the worker tracking it, once tracking is under way.
        bus.wait_for("poses of frame 30", poses_with_seq_at_least(30), 90)

        def owner_of_first_object(events):
            objects = sorted(o.id for o in events["MFOT_POSES"][-1][1].objects)
            for _, hb in reversed(events["MFOT_HEARTBEAT"]):
                if objects and hb.object_id == objects[0]:
                    return hb.object_id, hb.worker_id
            return None

        object_id, worker = bus.wait_for("a heartbeat naming an object", owner_of_first_object, 10)
        before = [o for o in bus.snapshot("MFOT_POSES")[-1][1].objects if o.id == object_id][0]
        pid = group.kill(f"tracker{worker}")
        killed_at = time.monotonic()
        print(f"killed worker {worker} (pid {pid}) tracking object {object_id}")

        def reassigned(events):
            for t, m in events["MFOT_MODEL_.*"]:
                if t > killed_at and m.object_id == object_id and m.worker_id not in (worker, -1):
                    return t, m.worker_id
            return None

        assigned_at, new_worker = bus.wait_for("the object's model sent to another worker", reassigned,
                                               WORKER_TIMEOUT_S + 5)
        taken_at, _ = bus.wait_for(
            "a heartbeat of the new worker naming the object",
            lambda ev: next(((t, hb) for t, hb in ev["MFOT_HEARTBEAT"]
                             if t > assigned_at and hb.worker_id == new_worker and hb.object_id == object_id), None),
            5)
        print(f"declared and reassigned to worker {new_worker} {assigned_at - killed_at:.2f} s after the kill, "
              f"taken {taken_at - assigned_at:.2f} s later")
        self.assertLess(assigned_at - killed_at, WORKER_TIMEOUT_S + 0.7, "declared dead after the worker timeout")
        self.assertLess(taken_at - assigned_at, 1.0, "another worker holds the object within 1 s")

        # Poses keep the id and keep flowing, and the object is tracked again from its last pose.
        after_seq = bus.wait_for("poses after the reassignment", lambda ev: next(
            (p.frame_seq for t, p in ev["MFOT_POSES"] if t > taken_at), None), 10)
        bus.wait_for("20 more frames of poses", poses_with_seq_at_least(after_seq + 20), 30)
        after = [p for t, p in bus.snapshot("MFOT_POSES") if t > killed_at]
        for p in after:
            self.assertIn(object_id, {o.id for o in p.objects}, f"frame {p.frame_seq}")
        fresh = [o for p in after if p.frame_seq >= after_seq for o in p.objects if o.id == object_id and not o.stale]
        self.assertGreater(len(fresh), 15, "the new worker's estimates arrive")
        moved = max(sum((a - b) ** 2 for a, b in zip(o.position, before.position)) ** 0.5 for o in fresh)
        self.assertLess(moved, 0.01, "the static object is tracked on from where it was")
        times = [t for t, p in bus.snapshot("MFOT_POSES") if t > killed_at]
        gaps = [b - a for a, b in zip(times, times[1:])]
        self.assertLess(max(gaps), WORKER_TIMEOUT_S + 1.5, "poses stall at most for the worker timeout")
        # The group runs to the end; it reports the worker it could not restart.
        self.assertEqual(group.wait(180), 1, group.report())
        self.assertIn(f"tracker{worker} stopped: it exited with -9; not restarting", group.stdout_path.read_text())
        self.assertEqual([p.frame_seq for _, p in logged(group.out, "MFOT_POSES")], list(range(frames)),
                         "no frame lost")

    def test_restarted_tracker_gets_its_object_back(self):
        """With the default restarts, SIGKILL a worker: mfot-run restarts it at once, the merger
        sends the restarted worker its object again, and no frame is lost."""
        frames = 80
        group, bus = self.start_group(7716, "--scenario", "static", "--workers", "3", "--max-frames", str(frames))
        bus.wait_for("poses of frame 20", poses_with_seq_at_least(20), 90)
        hb = bus.wait_for("a heartbeat naming an object", lambda ev: next(
            (hb for _, hb in reversed(ev["MFOT_HEARTBEAT"]) if hb.object_id >= 0), None), 10)
        old = group.kill(f"tracker{hb.worker_id}")
        killed_at = time.monotonic()
        bus.wait_for("the worker restarted", lambda ev: group.pids().get(f"tracker{hb.worker_id}", old) != old, 10)
        taken_at = bus.wait_for("a heartbeat naming the object again", lambda ev: next(
            (t for t, h in ev["MFOT_HEARTBEAT"] if t > killed_at and h.object_id == hb.object_id), None),
            WORKER_TIMEOUT_S + 5)
        print(f"object {hb.object_id} held again {taken_at - killed_at:.2f} s after its worker was killed")
        self.assertLess(taken_at - killed_at, WORKER_TIMEOUT_S + 1.0)
        # A restart is a problem mfot-run reports (exit 1), though no frame was lost.
        self.assertEqual(group.wait(180), 1, group.report())
        said = group.stdout_path.read_text()
        self.assertRegex(said, rf"PROBLEM +tracker{hb.worker_id} was restarted 1 time", group.report())
        self.assertNotIn("got no poses", said, group.report())
        poses = logged(group.out, "MFOT_POSES")
        self.assertEqual([p.frame_seq for _, p in poses], list(range(frames)), "no frame lost")
        self.assertFalse(any(o.stale for o in poses[-1][1].objects), "every object tracked at the end")

    # 3 ------------------------------------------------------------------------------------------

    def test_restarted_preprocess_and_merger(self):
        """SIGKILL preprocess, then the merger: mfot-run restarts each, the other services wait and
        resume, only frames published during an outage lack poses, and the restarted merger resumes
        the objects its workers hold under the same ids."""
        frames = 110
        config = write_config(self.dir / "config.yaml", capture={"lockstep_timeout_s": 2.0})
        group, bus = self.start_group(7714, "--config", str(config), "--scenario", "static", "--workers", "3",
                                      "--max-frames", str(frames))
        bus.wait_for("poses of frame 25", poses_with_seq_at_least(25), 90)
        others = {n: p for n, p in group.pids().items() if n not in ("preprocess", "merger", "logger")}
        outages = []
        for service, next_seq in (("preprocess", 55), ("merger", 85)):
            last_seq = bus.snapshot("MFOT_POSES")[-1][1].frame_seq
            old = group.kill(service)
            print(f"killed {service} (pid {old}) after poses of frame {last_seq}")
            bus.wait_for(f"{service} restarted", lambda ev: group.pids().get(service, old) != old, 15)
            resumed_t, resumed = bus.wait_for(f"poses after the {service} restart",
                                              poses_with_seq_at_least(last_seq + 3), 30)
            outages.append((service, last_seq, resumed.frame_seq))
            if service == "merger":
                self.assertEqual(len(resumed.objects), 3, "the restarted merger finds the three objects again")
                before = next(p for _, p in reversed(bus.snapshot("MFOT_POSES")) if p.frame_seq <= last_seq)
                self.assertEqual({o.id for o in resumed.objects}, {o.id for o in before.objects},
                                 "the restarted merger resumed the objects its workers hold: the same ids")
                # ... with their models and poses: a static scene, so each pose is where it was.
                for o in resumed.objects:
                    old_pose = next(b for b in before.objects if b.id == o.id)
                    self.assertLess(max(abs(a - b) for a, b in zip(o.position, old_pose.position)), 0.02,
                                    f"object {o.id} resumed at its pose")
            bus.wait_for(f"poses of frame {next_seq}", poses_with_seq_at_least(next_seq), 60)
        # Restarts and the frames lost meanwhile are problems mfot-run names in its summary (exit 1).
        self.assertEqual(group.wait(120), 1, group.report())
        said = group.stdout_path.read_text()
        for service in ("preprocess", "merger"):
            self.assertRegex(said, rf"PROBLEM +{service} was restarted 1 time", group.report())
        self.assertEqual({n: p for n, p in group.pids().items() if n in others}, others,
                         "no other service was restarted")

        published = sorted(frame_seq(data) for _, data in logged(group.out, "MFOT_FRAME"))
        self.assertEqual(published, list(range(frames)))
        answered = [p.frame_seq for _, p in logged(group.out, "MFOT_POSES")]
        self.assertEqual(answered, sorted(set(answered)), "poses in order, none twice")
        missing = sorted(set(published) - set(answered))
        print(f"outages (service, last frame before, first after): {outages}; frames without poses: {missing}")
        for seq in missing:
            self.assertTrue(any(before < seq < after for _, before, after in outages),
                            f"frame {seq} lacks poses outside an outage")
        self.assertLessEqual(len(missing), 4)
        if missing:
            self.assertIn(f"PROBLEM           {len(missing)} of {frames} published frames got no poses", said)
        # The restarted merger continued poses.csv: one header, rows from both sides of the restart.
        lines = (group.out / "poses.csv").read_text().splitlines()
        self.assertEqual(sum(line.startswith("frame,") for line in lines), 1)
        rows = {int(line.split(",")[0]) for line in lines[1:]}
        self.assertEqual(rows, set(answered))
        # Trackers kept the objects they held across the merger restart: every object is tracked
        # (not stale) by the end, under the ids it had from the start.
        last = logged(group.out, "MFOT_POSES")[-1][1]
        self.assertEqual(len(last.objects), 3)
        self.assertFalse(any(o.stale for o in last.objects))
        first_ids = {o.id for _, p in logged(group.out, "MFOT_POSES") if p.frame_seq <= 25 for o in p.objects}
        self.assertLessEqual({o.id for o in last.objects}, first_ids, "no id churn across both restarts")

    # 4 ------------------------------------------------------------------------------------------

    def test_stalled_and_ending_source(self):
        """A TUM folder whose frame 15 cannot be read for a while: capture says on MFOT_STATUS that
        its source stalled while the group stays up, resumes when the frame comes, and when the
        folder ends says so and the group ends cleanly with poses for every frame."""
        frames, stall_at = 40, 15
        folder = self.dir / "tum"
        res = subprocess.run([str(BUILD / "services/simulate/mfot-simulate"), str(folder), "--scenario", "static",
                              "--frames", str(frames)], capture_output=True, text=True, timeout=300)
        self.assertEqual(res.returncode, 0, res.stdout + res.stderr)
        depth_list = [line.split() for line in (folder / "depth.txt").read_text().splitlines()
                      if line and not line.startswith("#")]
        self.assertEqual(len(depth_list), frames)
        blocked = folder / depth_list[stall_at][1]
        content = blocked.read_bytes()
        blocked.unlink()
        os.mkfifo(blocked)  # reading it blocks until the test writes the image into it

        config = write_config(self.dir / "config.yaml", capture={"source": "tum", "folder": str(folder)})
        group, bus = self.start_group(7715, "--config", str(config), "--workers", "3")
        feeder = None
        try:
            def capture_says(text):
                return lambda ev: next((t for t, s in ev["MFOT_STATUS"] if s.service == "capture" and text in s.message),
                                       None)

            stalled_at = bus.wait_for("capture reporting a stalled source", capture_says("source stalled"), 90)
            # The stall goes on being reported while the rest of the group stays up.
            bus.wait_for("a later stall report", lambda ev: next(
                (t for t, s in ev["MFOT_STATUS"] if s.service == "capture" and t > stalled_at + 0.5
                 and "source stalled" in s.message), None), 10)
            self.assertIsNone(group.proc.poll(), "the group stays up while the source stalls")
            answered = max(p.frame_seq for _, p in bus.snapshot("MFOT_POSES"))
            self.assertEqual(answered, stall_at - 1, "every frame before the stall is answered")
            bus.wait_for("the merger and trackers alive during the stall", lambda ev: len(
                {s.service + str(s.instance) for t, s in ev["MFOT_STATUS"] if t > stalled_at}) >= 4, 10)

            def feed():
                with open(blocked, "wb") as fifo:
                    fifo.write(content)

            feeder = threading.Thread(target=feed, daemon=True)
            feeder.start()
            bus.wait_for("capture reporting that its source resumed", capture_says("source resumed"), 20)
            bus.wait_for("capture reporting the end of its source",
                         capture_says(f"source ended after {frames} frames"), 60)
            self.assertGroupOk(group, group.wait(60))
        finally:
            if feeder is None:
                # The test failed before feeding the FIFO: give a reader blocked on it an end of file.
                try:
                    os.close(os.open(blocked, os.O_WRONLY | os.O_NONBLOCK))
                except OSError:
                    pass  # nobody is reading it
        self.assertEqual([p.frame_seq for _, p in logged(group.out, "MFOT_POSES")], list(range(frames)))


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1] + sys.argv[1:], verbosity=2)
