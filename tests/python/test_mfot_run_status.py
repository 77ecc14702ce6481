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
