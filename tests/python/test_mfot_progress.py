"""scripts/mfot_progress.py off a terminal (CI, logs, pipes): plain lines with counts and an ETA, no
bar, no carriage returns or escape codes, rate-limited for running measures; MFOT_PROGRESS=off is
silent; standard output untouched. Standard library only."""

from __future__ import annotations

import io
import os
import subprocess
import sys
import textwrap
import unittest
from pathlib import Path
from unittest import mock

SOURCE_DIR = Path(os.environ.get("MFOT_SOURCE_DIR", Path(__file__).resolve().parents[2]))
sys.path.insert(0, str(SOURCE_DIR / "scripts"))
import mfot_progress  # noqa: E402


class FakeClock:
    def __init__(self):
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


class NotATerminalTest(unittest.TestCase):
    def setUp(self):
        patcher = mock.patch.dict(os.environ, {"MFOT_PROGRESS": "auto"})
        patcher.start()
        self.addCleanup(patcher.stop)

    def test_steps_are_plain_lines_with_eta(self):
        stream, clock = io.StringIO(), FakeClock()
        self.assertEqual(mfot_progress.choose_backend(stream), "lines")
        with mfot_progress.Progress("bench", total=4, unit="runs", stream=stream, clock=clock) as bar:
            self.assertEqual(bar.backend, "lines")
            self.assertIsNone(bar.eta_s())
            clock.now += 30.0
            bar.advance(note="stack jcsd")
            clock.now += 30.0
            bar.advance(note="stack p2p")
            self.assertAlmostEqual(bar.eta_s(), 60.0)
        lines = stream.getvalue().splitlines()
        self.assertEqual(lines, [
            "[bench] 1/4 runs (25 %), elapsed 0:30, ETA 1:30: stack jcsd",
            "[bench] 2/4 runs (50 %), elapsed 1:00, ETA 1:00: stack p2p",
            "[bench] 2/4 runs in 1:00",
        ])
        self.assertNotIn("\r", stream.getvalue())
        self.assertNotIn("\x1b", stream.getvalue())

    def test_running_measure_is_rate_limited(self):
        stream, clock = io.StringIO(), FakeClock()
        bar = mfot_progress.Progress("soak", total=600, unit="s", stream=stream, clock=clock, interval_s=60.0)
        for second in range(1, 601):
            clock.now += 1.0
            bar.update(second, note=f"{second * 30} frames")
        bar.close()
        lines = stream.getvalue().splitlines()
        # The first update, one a minute after it, the last (600 of 600) and the closing line.
        self.assertEqual(len(lines), 1 + 9 + 1 + 1, lines)
        self.assertEqual(lines[0], "[soak] 1/600 s (0 %), elapsed 0:01, ETA 9:59: 30 frames")
        self.assertEqual(lines[-2], "[soak] 600/600 s (100 %), elapsed 10:00, ETA 0:00: 18000 frames")
        self.assertEqual(lines[-1], "[soak] 600/600 s in 10:00")

    def test_hours_and_unknown_eta(self):
        self.assertEqual(mfot_progress.clock_text(3725), "1:02:05")
        self.assertEqual(mfot_progress.clock_text(None), "?")
        stream, clock = io.StringIO(), FakeClock()
        bar = mfot_progress.Progress("x", total=3, stream=stream, clock=clock)
        bar.update(0, note="starting")
        self.assertIn("ETA ?", stream.getvalue())
        bar.close()

    def test_off_is_silent(self):
        stream = io.StringIO()
        with mock.patch.dict(os.environ, {"MFOT_PROGRESS": "off"}):
            with mfot_progress.Progress("quiet", total=2, stream=stream) as bar:
                bar.advance()
                bar.advance()
        self.assertEqual(stream.getvalue(), "")

    def test_write_goes_to_stdout(self):
        stream, out = io.StringIO(), io.StringIO()
        with mock.patch.object(sys, "stdout", out):
            with mfot_progress.Progress("w", total=1, stream=stream):
                mfot_progress.write("[w] a log line")
            mfot_progress.write("[w] after")
        self.assertEqual(out.getvalue(), "[w] a log line\n[w] after\n")
        self.assertEqual(stream.getvalue(), "")

    def test_a_script_piped(self):
        """As the benchmark scripts use it, with stderr and stdout pipes: lines on stderr, stdout as printed."""
        code = textwrap.dedent(f"""
            import sys
            sys.path.insert(0, {str(SOURCE_DIR / 'scripts')!r})
            import mfot_progress
            with mfot_progress.Progress("demo", total=3, unit="scenes") as bar:
                for k in range(3):
                    mfot_progress.write(f"[demo] scene {{k}}")
                    bar.advance(note=f"scene {{k}}")
            print('{{"result": 1}}')
        """)
        res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60,
                             env=dict(os.environ, MFOT_PROGRESS="auto"))
        self.assertEqual(res.returncode, 0, res.stderr)
        self.assertEqual(res.stdout.splitlines(), ["[demo] scene 0", "[demo] scene 1", "[demo] scene 2", '{"result": 1}'])
        err = res.stderr.splitlines()
        self.assertEqual(len(err), 4, res.stderr)
        self.assertTrue(err[0].startswith("[demo] 1/3 scenes (33 %), elapsed 0:00, ETA "), err[0])
        self.assertTrue(err[-1].startswith("[demo] 3/3 scenes in "), err[-1])
        self.assertNotIn("\r", res.stderr)
        self.assertNotIn("\x1b", res.stderr)


if __name__ == "__main__":
    unittest.main()
