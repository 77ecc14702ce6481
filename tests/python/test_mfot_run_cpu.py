"""scripts/mfot-run's CPU accounting: each service's CPU time read from /proc/PID/stat (an exited
process's final figure before it is reaped, restarts added up) and the summary's per-frame line."""

from __future__ import annotations

import os
import sys
import tempfile
import unittest
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "scripts"))
from mfot_script_module import load_script  # noqa: E402

mfot_run = load_script(REPO / "scripts" / "mfot-run", "mfot_run")

# A child that spends at least this much CPU time and exits.
BURN_S = 0.3
BURN = ("import time\n"
        f"while time.process_time() < {BURN_S}:\n"
        "    sum(range(1000))\n")


def stat_line(comm: str, utime: int, stime: int) -> str:
    # pid (comm) state ppid pgrp session tty tpgid flags minflt cminflt majflt cmajflt utime stime ...
    return f"4321 ({comm}) S 1 4321 4321 0 -1 4194560 120 0 0 0 {utime} {stime} 0 0 20 0 3 0 1000 1000 200\n"


class CpuSecondsOfStatTest(unittest.TestCase):
    def test_utime_and_stime_in_seconds(self):
        ticks = mfot_run.CLOCK_TICKS
        self.assertAlmostEqual(mfot_run.cpu_seconds_of_stat(stat_line("mfot-merger", 3 * ticks, ticks)), 4.0)

    def test_a_command_name_with_spaces_and_parentheses(self):
        ticks = mfot_run.CLOCK_TICKS
        self.assertAlmostEqual(mfot_run.cpu_seconds_of_stat(stat_line("a) b (c) 7 8", 2 * ticks, 0)), 2.0)

    def test_malformed_text_gives_none(self):
        self.assertIsNone(mfot_run.cpu_seconds_of_stat(""))
        self.assertIsNone(mfot_run.cpu_seconds_of_stat("4321 (x) S 1 2"))
        self.assertIsNone(mfot_run.cpu_seconds_of_stat(stat_line("x", 10, 1).replace(" 10 1 ", " ten 1 ")))


class ServiceCpuTest(unittest.TestCase):
    def wait_exited_unreaped(self, service) -> None:
        # Blocks until the child has exited, leaving it for poll() to reap (as the supervision loop does).
        os.waitid(os.P_PID, service.proc.pid, os.WEXITED | os.WNOWAIT)

    def test_an_exited_process_keeps_its_cpu_time_and_restarts_add_up(self):
        with tempfile.TemporaryDirectory() as tmp:
            service = mfot_run.Service("burner", [sys.executable, "-c", BURN], Path(tmp) / "burner.log")
            self.assertEqual(service.cpu_seconds(), 0.0)
            service.start()
            self.wait_exited_unreaped(service)
            self.assertEqual(service.poll(), 0)
            first = service.cpu_seconds()
            self.assertGreaterEqual(first, BURN_S - 1.0 / mfot_run.CLOCK_TICKS)
            self.assertLess(first, 30.0)
            self.assertEqual(service.poll(), 0)  # reaped: nothing more is read
            self.assertEqual(service.cpu_seconds(), first)

            service.restarts += 1
            service.start()
            self.wait_exited_unreaped(service)
            self.assertEqual(service.poll(), 0)
            self.assertGreaterEqual(service.cpu_seconds(), first + BURN_S - 1.0 / mfot_run.CLOCK_TICKS)
            service.stop()


    def test_a_stopped_process_has_its_cpu_time_up_to_the_stop(self):
        with tempfile.TemporaryDirectory() as tmp:
            ready = Path(tmp) / "ready"
            os.mkfifo(ready)
            # Burns, says so through the FIFO, then waits for the stop's signal.
            code = BURN + f"open({str(ready)!r}, 'w').write('x')\nimport signal\nsignal.pause()\n"
            service = mfot_run.Service("burner", [sys.executable, "-c", code], Path(tmp) / "burner.log")
            service.start()
            with open(ready) as f:  # blocks until the child has burnt its share
                self.assertEqual(f.read(), "x")
            self.assertIsNone(service.poll())
            self.assertEqual(service.cpu_seconds(), 0.0)  # running: not read while it runs
            service.stop()
            self.assertGreaterEqual(service.cpu_seconds(), BURN_S - 1.0 / mfot_run.CLOCK_TICKS)
            self.assertLess(service.cpu_seconds(), 30.0)


class CpuSummaryTest(unittest.TestCase):
    def test_per_frame_figures_and_busy_cores(self):
        s = {"cpu_s": {"capture": 15.4, "merger": 12.7, "tracker0": 3.0}, "frames": 842, "elapsed_s": 31.1, "cores": 2}
        figures = mfot_run.cpu_figures(s)
        self.assertEqual(figures, {"cpu_ms_per_frame": {"capture": 18.29, "merger": 15.08, "tracker0": 3.56},
                                   "cores_busy": 1.0})
        s.update(figures)
        self.assertEqual(mfot_run.cpu_summary(s),
                         "capture 18.3 ms, merger 15.1 ms, tracker0 3.6 ms; 1.00 cores busy of 2")

    def test_nothing_without_frames_or_figures(self):
        self.assertEqual(mfot_run.cpu_figures({"cpu_s": {"capture": 1.0}, "frames": 0, "elapsed_s": 3.0}), {})
        self.assertEqual(mfot_run.cpu_figures({"frames": 10, "elapsed_s": 3.0}), {})
        self.assertEqual(mfot_run.cpu_summary({"frames": 10, "elapsed_s": 3.0}), "")


if __name__ == "__main__":
    unittest.main()
