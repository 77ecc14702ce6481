#!/usr/bin/env python3
"""I/O errors through the real process group (scripts/mfot-run, CPU backend, one worker):

- a disk that fills up while recording (a 2 MB tmpfs as the run folder; needs root and mount, else
  skipped with the reason): mfot-run names the path and the system's reason, stops the whole group
  (no process of it is left) and exits non-zero; what was recorded before still reads;
- processes.json that cannot be written (/dev/full): the group is stopped, nothing crashes;
- a full label folder only (a 64 KiB tmpfs): the merger exits with 3 naming the image, is not restarted,
  and the group stops;
- a replay of a file that is not an LCM log, and of a truncated one: the group fails with the reason
  (the byte offset of the broken event) instead of "0 frames published".

Each waits for mfot-run to end (a bounded subprocess wait), never on sleeps."""

from __future__ import annotations

import os
import random
import shutil
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "scripts"))
import mfot_lcm  # noqa: E402

BUILD = Path(os.environ.get("MFOT_BUILD_DIR", REPO / "build"))
GROUP_TIMEOUT_S = 400


def run_group(out: Path, *args: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, MFOT_LCM_URL=f"udpm://239.255.76.67:{random.randint(20000, 60000)}?ttl=0")
    return subprocess.run([sys.executable, str(REPO / "scripts/mfot-run"), "--build-dir", str(BUILD), "--out", str(out),
                           "--quiet", "--backend", "cpu", "--workers", "1", *args], env=env, capture_output=True,
                          text=True, timeout=GROUP_TIMEOUT_S)


def processes_mentioning(text: str) -> list[str]:
    """Command lines of live processes that name `text` (a run folder every service of a group is given)."""
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit() or int(entry) == os.getpid():
            continue
        try:
            argv = Path(f"/proc/{entry}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
            state = Path(f"/proc/{entry}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if text in argv and state != "Z":
            found.append(f"{entry}: {argv}")
    return found


def explain(res: subprocess.CompletedProcess, run: Path) -> str:
    logs = "".join(f"\n--- {p.name}\n" + p.read_text(errors="replace")[-1500:] for p in sorted((run / "logs").glob("*.log")))
    return f"exit {res.returncode}\n{res.stdout[-4000:]}\n{res.stderr[-2000:]}{logs}"


class IoErrorTest(unittest.TestCase):
    def setUp(self):
        for name in ("capture", "preprocess", "tracker", "merger"):
            if not (BUILD / "services" / name / f"mfot-{name}").is_file():
                self.skipTest(f"mfot-{name} is not built in {BUILD}")
        self.tmp = Path(tempfile.mkdtemp(prefix="mfot_io_errors_"))
        self.addCleanup(shutil.rmtree, self.tmp, True)

    def mount_small_disk(self, where: Path, size: str) -> Path:
        """A tmpfs of `size` at `where`, unmounted after the test; skips the test when it cannot be mounted."""
        if os.geteuid() != 0:
            self.skipTest("mounting a small tmpfs needs root")
        where.mkdir(parents=True)
        mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(where)],
                                 capture_output=True, text=True)
        if mounted.returncode != 0:
            self.skipTest(f"cannot mount a tmpfs: {mounted.stderr.strip()}")
        self.addCleanup(subprocess.run, ["umount", "-l", str(where)], capture_output=True)
        return where

    def test_a_full_disk_stops_the_whole_group_with_the_path(self):
        if not shutil.which("lcm-logger"):
            self.skipTest("lcm-logger is not installed")
        disk = self.mount_small_disk(self.tmp / "disk", "2m")
        run = disk / "run"
        res = run_group(run, "--scenario", "stack", "--max-frames", "100")
        said = explain(res, run)
        self.assertEqual(res.returncode, 1, said)
        # The reason the group stopped names a file on the full disk and the system's reason.
        self.assertRegex(res.stdout, rf"error: [^\n]*{run}/[^\n]*No space left on device[^\n]*; stopping the process group",
                         said)
        self.assertIn("stopping the process group", res.stdout, said)
        self.assertIn("PROBLEM", res.stdout, said)
        self.assertNotIn("Traceback", res.stdout + res.stderr, said)
        self.assertEqual(processes_mentioning(str(run)), [], said)
        # What was recorded before the disk filled still reads, up to a named byte at most.
        events = []
        try:
            for event in mfot_lcm.read_log(run / "mfot.lcmlog"):
                events.append(event.channel)
        except mfot_lcm.LcmLogError as e:
            self.assertRegex(str(e), r"at byte \d+", said)
        self.assertIn("MFOT_STATUS", events, said)
        self.assertTrue((run / "poses.csv").read_text().startswith("frame,utime,object_id"), said)

    def test_label_images_that_cannot_be_written_are_a_named_problem(self):
        """Only the label images' folder is full (a 64 KiB tmpfs): mfot-labels, drawing them from the log after
        the run, names the image and the system's reason, and mfot-run exits 1 with it as a PROBLEM; the poses
        and the log are whole."""
        run = self.tmp / "labels-full"
        labels = self.mount_small_disk(run / "labels", "64k")
        res = run_group(run, "--scenario", "stack", "--max-frames", "100")
        said = explain(res, run)
        self.assertEqual(res.returncode, 1, said)
        self.assertRegex(res.stdout, rf"PROBLEM +label images: [^\n]*{labels}/\d{{6}}\.png\.tmp: cannot write PNG: "
                                     r"[^\n]*No space left on device", said)
        self.assertNotIn("restarting", res.stdout, said)
        self.assertEqual(processes_mentioning(str(run)), [], said)
        self.assertGreater(len(list(mfot_lcm.read_log(run / "mfot.lcmlog"))), 0, said)  # reads to its end
        poses = (run / "poses.csv").read_text().splitlines()
        self.assertEqual(len({line.split(",")[0] for line in poses[1:]}), 100, said)  # every frame posed

    def test_an_unwritable_processes_json_stops_the_group(self):
        """processes.json cannot be written (its temporary file is /dev/full: ENOSPC on every write): mfot-run
        names the file and the reason, stops the services it started and exits 1 instead of crashing."""
        if not Path("/dev/full").exists():
            self.skipTest("/dev/full is missing")
        run = self.tmp / "pids-full"
        run.mkdir()
        (run / "processes.json.tmp").symlink_to("/dev/full")
        res = run_group(run, "--scenario", "stack", "--max-frames", "100")
        said = explain(res, run)
        self.assertEqual(res.returncode, 1, said)
        self.assertRegex(res.stdout, rf"error: cannot write {run}/processes.json.tmp: No space left on device; "
                                     r"stopping the process group", said)
        self.assertNotIn("Traceback", res.stdout + res.stderr, said)
        self.assertEqual(processes_mentioning(str(run)), [], said)

    def test_a_replay_of_a_foreign_file_says_it_is_not_an_lcm_log(self):
        run = self.tmp / "foreign"
        res = run_group(run, "--replay", "/bin/ls")
        said = explain(res, run)
        self.assertEqual(res.returncode, 1, said)
        self.assertIn("/bin/ls: starts with 0x7f454c46, not the LCM log sync word 0xeda1da01: not an LCM log",
                      res.stdout, said)
        self.assertRegex(res.stdout, r"PROBLEM +capture exited with 1", said)
        self.assertEqual(processes_mentioning(str(run)), [], said)

    def test_a_replay_of_a_truncated_log_fails_with_the_byte_offset(self):
        log = self.tmp / "truncated.lcmlog"
        mfot_lcm.write_log(log, [(1, "MFOT_NOTE", b"before"), (2, "MFOT_FRAME", b"x" * 100)])
        log.write_bytes(log.read_bytes()[:-30])  # ends inside the second event (at byte 43)
        run = self.tmp / "truncated"
        res = run_group(run, "--replay", str(log))
        said = explain(res, run)
        self.assertEqual(res.returncode, 1, said)
        self.assertIn(f"{log} at byte 43 of", res.stdout, said)
        self.assertIn("event 1 is truncated", res.stdout, said)


if __name__ == "__main__":
    unittest.main()
