"""scripts/mfot-run's live status: a table of at most 100 columns, one row per service, redrawn in
a terminal, and one plain summary line for logs."""

from __future__ import annotations

import sys
import unittest
from pathlib import Path
from types import SimpleNamespace

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "scripts"))
from mfot_script_module import load_script  # noqa: E402

mfot_run = load_script(REPO / "scripts" / "mfot-run", "mfot_run")


def status(service: str, instance: int = 0, **kw) -> SimpleNamespace:
    values = dict(service=service, instance=instance, rate_hz=29.7, latency_p50_ms=23.8, latency_p99_ms=38.8,
                  frames=842, queue_depth=1, malformed=0, backend="jcsd-cpu", host="robot-gpu-computer-01", message="")
    values.update(kw)
    return SimpleNamespace(**values)


class StatusTableTest(unittest.TestCase):
    def statuses(self) -> dict:
        s = {"merger": status("merger", backend="cpu"), "preprocess": status("preprocess", backend="cpu"),
             "capture": status("capture", backend="sim")}
        for w in range(6):
            s[f"tracker{w}"] = status("tracker", w, latency_p99_ms=10.0 + w, host="x" * 60)
        s["tracker99001"] = status("tracker", 99001, malformed=3, backend="jcsd-cuda-with-a-long-name")
        return s

    def test_one_row_per_service_within_100_columns(self):
        rows = mfot_run.status_table(self.statuses(), ["tracker3"])
        self.assertEqual(len(rows), 1 + 10 + 1)  # header, services, what stopped
        self.assertTrue(rows[0].startswith("service"))
        self.assertTrue(all(len(r) <= 100 for r in rows), max(rows, key=len))
        merger = next(r for r in rows if r.startswith("merger"))
        for figure in ("29.7", "23.80", "38.80", "842", "robot-gpu-computer-01"):
            self.assertIn(figure, merger)
        self.assertEqual(rows[-1], "stopped: tracker3")

    def test_the_plain_line_summarises_for_a_log(self):
        line = mfot_run.status_summary(self.statuses(), [])
        self.assertLessEqual(len(line), 100)
        self.assertIn("poses 29.7 Hz", line)
        self.assertIn("slowest 99001", line)  # p99 38.8 ms, the largest
        self.assertIn("bad 3", line)
        self.assertIn("no merger status yet", mfot_run.status_summary({}, []))


def load_types_or_skip(test):
    sys.path.insert(0, str(REPO / "scripts"))
    import mfot_lcm  # noqa: PLC0415

    try:
        return mfot_lcm.load_types()
    except mfot_lcm.LcmError as e:
        test.skipTest(str(e))


class RunSummaryTest(unittest.TestCase):
    """The summary of a run's log: lost frames, undecodable (forged) messages and a log that does not read are
    counted and named, never raised; each makes the run a failure (exit 1) with the reason in words."""

    def setUp(self):
        self.types = load_types_or_skip(self)
        import tempfile  # noqa: PLC0415

        self.tmp = tempfile.TemporaryDirectory()
        self.addCleanup(self.tmp.cleanup)
        self.run_dir = Path(self.tmp.name)

    def frame(self, seq: int) -> bytes:
        f = self.types.frame_t()
        f.seq = seq
        f.utime = 1000 * seq
        f.depth_data = f.color_data = b""
        return f.encode()

    def poses(self, seq: int, ids=(1, 2)) -> bytes:
        p = self.types.poses_t()
        p.frame_seq = seq
        p.utime = 1000 * seq + 500
        for i in ids:
            o = self.types.object_pose_t()
            o.id = i
            p.objects.append(o)
        p.num_objects = len(p.objects)
        return p.encode()

    def write(self, events):
        import mfot_lcm  # noqa: PLC0415

        mfot_lcm.write_log(self.run_dir / "mfot.lcmlog", events)

    def summarise(self, source_ended=True):
        return mfot_run.summarise(self.run_dir, self.types, 1.0, self.run_dir / "no-evaluate", source_ended=source_ended)

    def services(self, **restarts):
        out = {}
        for name in ("logger", "merger", "preprocess", "tracker0", "capture"):
            out[name] = SimpleNamespace(restarts=restarts.get(name, 0), exit_code=None,
                                        log_path=self.run_dir / "logs" / f"{name}.log")
        return out

    def test_a_forged_pose_is_counted_not_raised_and_its_frame_is_lost(self):
        good = self.poses(1)
        self.write([(0, "MFOT_FRAME", self.frame(0)), (500, "MFOT_POSES", self.poses(0)),
                    (1000, "MFOT_FRAME", self.frame(1)), (1500, "MFOT_POSES", good[:-3]),  # does not decode
                    (2000, "MFOT_FRAME", self.frame(2)), (2500, "MFOT_POSES", self.poses(2))])
        s = self.summarise()
        self.assertEqual(s["undecodable"], {"MFOT_POSES": 1})
        self.assertEqual((s["frames"], s["frames_published"], s["frames_lost"], s["lost_frame_seqs"]), (2, 3, 1, [1]))
        problems = mfot_run.group_problems(s, self.services(), [], 0)
        self.assertEqual(problems, ["1 of 3 published frames got no poses (frames 1)"])

    def test_frames_in_flight_at_a_stop_are_not_lost_but_unposed_ones_at_a_source_end_are(self):
        self.write([(0, "MFOT_FRAME", self.frame(0)), (500, "MFOT_POSES", self.poses(0)),
                    (1000, "MFOT_FRAME", self.frame(1)), (2000, "MFOT_FRAME", self.frame(2))])
        stopped = self.summarise(source_ended=False)
        self.assertEqual((stopped["frames_lost"], stopped["frames_in_flight_at_stop"]), (0, 2))
        self.assertEqual(mfot_run.group_problems(stopped, self.services(), [], None), [])
        ended = self.summarise(source_ended=True)
        self.assertEqual((ended["frames_lost"], ended["lost_frame_seqs"]), (2, [1, 2]))

    def test_a_truncated_log_is_named_with_its_offset(self):
        self.write([(0, "MFOT_FRAME", self.frame(0)), (500, "MFOT_POSES", self.poses(0)),
                    (1000, "MFOT_FRAME", self.frame(1)), (1500, "MFOT_POSES", self.poses(1))])
        log = self.run_dir / "mfot.lcmlog"
        data = log.read_bytes()
        log.write_bytes(data[:-4])
        s = self.summarise()
        self.assertEqual(s["frames"], 1)
        self.assertRegex(s["log_error"], r"mfot.lcmlog at byte \d+ of \d+: event 3 is truncated")
        problems = mfot_run.group_problems(s, self.services(), [], 0)
        self.assertTrue(any(p.startswith("the run's log does not read to its end: ") for p in problems), problems)

    def test_restarts_a_failed_capture_and_fatal_errors_are_problems(self):
        self.write([(0, "MFOT_FRAME", self.frame(0)), (500, "MFOT_POSES", self.poses(0))])
        s = self.summarise()
        self.assertEqual(mfot_run.group_problems(s, self.services(), [], 0), [])
        problems = mfot_run.group_problems(s, self.services(merger=2), ["cannot write runs/x/processes.json: No space"],
                                           1, SimpleNamespace(message="source failed: bad log"))
        self.assertEqual(problems[0], "cannot write runs/x/processes.json: No space")
        self.assertTrue(problems[1].startswith("merger was restarted 2 times"), problems)
        self.assertTrue(problems[2].startswith("capture exited with 1: source failed: bad log"), problems)

    def test_a_foreign_or_empty_log_gives_no_frames_and_says_why(self):
        (self.run_dir / "mfot.lcmlog").write_bytes(b"\x7fELF" + bytes(100))
        s = self.summarise()
        self.assertIn("not an LCM log", s["log_error"])
        problems = mfot_run.group_problems(s, self.services(), [], 0)
        self.assertIn("no frame got poses", problems)


def alive(pid: int) -> bool:
    """True while `pid` runs (a zombie counts as gone)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def wait_for(condition, timeout: float = 10.0) -> bool:
    import time  # noqa: PLC0415

    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.02)
    return True


class ServiceLifetimeTest(unittest.TestCase):
    """No service outlives mfot-run: stop() ends a service's whole process group, and a service gets
    SIGTERM when mfot-run itself is killed."""

    def setUp(self):
        import tempfile  # noqa: PLC0415

        self.tmp = tempfile.TemporaryDirectory()
        self.addCleanup(self.tmp.cleanup)
        self.dir = Path(self.tmp.name)

    def pids_in(self, log: Path, count: int) -> list[int]:
        self.assertTrue(wait_for(lambda: log.is_file() and len(log.read_text().split()) >= count), "no pids written")
        return [int(p) for p in log.read_text().split()[:count]]

    def test_stop_ends_what_a_service_started_too(self):
        log = self.dir / "svc.log"
        svc = mfot_run.Service("svc", ["sh", "-c", "sleep 60 & echo $!; echo $$; wait"], log)
        svc.start()
        child, shell = self.pids_in(log, 2)
        self.assertTrue(alive(child) and alive(shell))
        svc.stop(timeout=5.0)
        self.assertTrue(wait_for(lambda: not alive(child)), "the service's own child outlived stop()")
        self.assertFalse(alive(shell))
        svc.stop()  # a second stop signals nothing

    def test_services_end_when_mfot_run_is_killed(self):
        import signal  # noqa: PLC0415
        import subprocess  # noqa: PLC0415

        log = self.dir / "sleeper.log"
        parent = subprocess.Popen([sys.executable, "-c", f"""
import sys, time
sys.path.insert(0, {str(REPO / 'scripts')!r})
from pathlib import Path
from mfot_script_module import load_script
m = load_script(Path({str(REPO / 'scripts' / 'mfot-run')!r}), 'mfot_run')
m.Service('sleeper', ['sh', '-c', 'echo $$; exec sleep 60'], Path({str(log)!r})).start()
time.sleep(60)
"""])
        self.addCleanup(parent.wait)
        self.addCleanup(parent.kill)
        (service,) = self.pids_in(log, 1)
        self.assertTrue(alive(service))
        parent.send_signal(signal.SIGKILL)  # no finally runs in mfot-run
        parent.wait()
        self.assertTrue(wait_for(lambda: not alive(service)), "a service outlived a killed mfot-run")


if __name__ == "__main__":
    unittest.main()


class LoopbackTransportTest(unittest.TestCase):
    """What a bare mfot-run checks before a group on one host starts (scripts/lib.sh sets it up)."""

    def test_small_buffers_and_a_missing_route_are_named(self):
        routes = "default via 10.0.0.1 dev eth0\nmulticast ff00::/8 dev eth0 table local proto kernel metric 256\n"
        problems = mfot_run.loopback_transport_problems(212992, routes)
        self.assertEqual(len(problems), 2)
        self.assertIn("212992", problems[0])
        self.assertIn("224.0.0.0/4", problems[1])

    def test_the_set_up_of_scripts_lib_sh_passes(self):
        routes = "224.0.0.0/4 dev lo scope link\n"
        self.assertEqual(mfot_run.loopback_transport_problems(64 * 1024 * 1024, routes), [])
        self.assertEqual(mfot_run.loopback_transport_problems(64 * 1024 * 1024, "multicast 224.0.0.0/4 dev lo\n"), [])

    def test_without_ip_only_the_buffers_are_checked(self):
        self.assertEqual(mfot_run.loopback_transport_problems(64 * 1024 * 1024, None), [])
        self.assertNotEqual(mfot_run.loopback_transport_problems(1024, None), [])
