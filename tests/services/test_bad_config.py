#!/usr/bin/env python3
"""Every service executable refuses a bad config at start: it exits with the configuration-refused
status (2) before doing anything else, and its log names the offending key and what is allowed.
Runs the real binaries of $MFOT_BUILD_DIR with small config files."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("MFOT_BUILD_DIR", REPO / "build")).resolve()
CONFIG_REFUSED = 2  # run_service_main's exit status for a ConfigError
# A port no other test uses, host-local: a binary that wrongly accepted a config must not disturb others.
LCM_URL = "udpm://239.255.76.67:7695?ttl=0"

# Service -> (binary, extra arguments).
SERVICES = {
    "capture": ("services/capture/mfot-capture", []),
    "preprocess": ("services/preprocess/mfot-preprocess", []),
    "tracker": ("services/tracker/mfot-tracker", ["--worker-id", "0"]),
    "merger": ("services/merger/mfot-merger", []),
    "inprocess": ("services/inprocess/mfot-inprocess", ["--max-frames", "1"]),
}
# Which config sections each service reads (mfot-inprocess reads all four).
READS = {
    "capture": {"capture"},
    "preprocess": {"preprocess"},
    "tracker": {"tracker"},
    "merger": {"merger"},
    "inprocess": {"capture", "preprocess", "tracker", "merger"},
}

# (section read, YAML text, texts the error must contain). Ranges appear as the loader prints them.
SECTION_CASES = [
    # unknown keys
    ("capture", "capture:\n  sceanrio: stack\n", ["capture.sceanrio", "unknown config key"]),
    ("preprocess", "preprocess:\n  voxelsize: 0.005\n", ["preprocess.voxelsize", "unknown config key"]),
    ("tracker", "tracker:\n  partciles: 100\n", ["tracker.partciles", "unknown config key"]),
    ("merger", "merger:\n  world:\n    translaton: [0, 0, 0]\n", ["merger.world.translaton", "unknown config key"]),
    # wrong types
    ("capture", "capture:\n  seed: abc\n", ["capture.seed", "expected a non-negative integer", "'abc'"]),
    ("preprocess", "preprocess:\n  cluster: maybe\n", ["preprocess.cluster", "expected a boolean", "'maybe'"]),
    ("tracker", "tracker:\n  particles: many\n", ["tracker.particles", "expected an integer", "'many'"]),
    ("merger", "merger:\n  alpha: [0.1]\n", ["merger.alpha", "expected a number"]),
    ("tracker", "tracker:\n  init_sigma: [0.1, 0.1]\n", ["tracker.init_sigma", "expected a list of 6 numbers"]),
    # out of range
    ("capture", "capture:\n  speed: 0\n", ["capture.speed", "out of range [0.001000, 100.000000]"]),
    ("capture", "capture:\n  scenario: maze\n", ["capture.scenario", "'maze'", "stack|contact|rotate|apart|static|random"]),
    ("preprocess", "preprocess:\n  voxel_size: 2\n", ["preprocess.voxel_size", "out of range [0.000100, 1.000000]"]),
    ("preprocess", "preprocess:\n  crop_min: [0, 0, 2]\n  crop_max: [1, 1, 1]\n", ["preprocess:", "crop_min"]),
    ("tracker", "tracker:\n  particles: 0\n", ["tracker.particles", "out of range [1, 100000]"]),
    ("tracker", "tracker:\n  backend: opencl\n", ["tracker.backend", "'opencl'", "auto|cuda|cpu|point-to-point"]),
    ("tracker", "tracker:\n  lambda: -1\n", ["tracker.lambda", "out of range (0.000000, 1000.000000]"]),
    ("merger", "merger:\n  alpha: 1.5\n", ["merger.alpha", "out of range [0.000000, 1.000000]"]),
    ("merger", "merger:\n  tau: 0\n", ["merger.tau", "out of range [0.000100, 0.100000]"]),
    ("merger", "merger:\n  world:\n    rotation: [2, 0, 0, 0]\n", ["merger.world", "unit quaternion"]),
    # a setting another one bounds (a model holds at least the points an object is born with)
    ("merger", "merger:\n  max_model_points: 10\n", ["merger:", "max_model_points", "min_object_points"]),
]

# Errors of the file itself, refused by every service: (name, file text, texts the error must contain).
FILE_CASES = [
    ("misspelt section", "trackr:\n  particles: 100\n",
     ["unknown config section 'trackr'", "group|capture|preprocess|tracker|merger|pcl_baseline"]),
    ("syntax error", "tracker:\n  particles: [1, 2\n", ["YAML syntax error"]),
    ("not a mapping", "- tracker\n- merger\n", ["top level must be a mapping"]),
]


class BadConfigTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.addCleanup(self.tmp.cleanup)

    def run_service(self, service: str, config_text: str | None, config_name: str = "bad.yaml"):
        binary, extra = SERVICES[service]
        path = BUILD / binary
        self.assertTrue(path.is_file(), f"{path} is not built")
        config = Path(self.tmp.name) / config_name
        if config_text is not None:
            config.write_text(config_text)
        argv = [str(path), "--config", str(config), *extra]
        if service != "inprocess":
            argv += ["--lcm-url", LCM_URL]
        try:
            res = subprocess.run(argv, capture_output=True, text=True, timeout=60, cwd=self.tmp.name)
        except subprocess.TimeoutExpired:
            self.fail(f"{service} accepted the config and kept running:\n{config_text}")
        return res.returncode, res.stdout + res.stderr

    def assert_refused(self, service: str, config_text: str | None, expected: list[str], config_name="bad.yaml"):
        code, output = self.run_service(service, config_text, config_name)
        self.assertEqual(code, CONFIG_REFUSED, f"{service} exit status for\n{config_text}\noutput:\n{output}")
        self.assertIn("configuration refused", output)
        for text in expected:
            self.assertIn(text, output, f"{service} error for\n{config_text}")

    def test_section_errors_name_the_key_and_the_allowed_values(self):
        for service, sections in READS.items():
            for section, text, expected in SECTION_CASES:
                if section in sections:
                    with self.subTest(service=service, config=text):
                        self.assert_refused(service, text, expected)

    def test_file_errors_are_refused_by_every_service(self):
        for service in SERVICES:
            for name, text, expected in FILE_CASES:
                with self.subTest(service=service, case=name):
                    self.assert_refused(service, text, expected)
            with self.subTest(service=service, case="missing file"):
                self.assert_refused(service, None, ["missing.yaml", "cannot open config file"], "missing.yaml")

    def test_the_group_stops_at_once_when_a_service_refuses_the_config(self):
        # scripts/mfot-run starts the services, sees the merger refuse and stops them before the source starts
        # (not after its wait for every service's first status), saying why and exiting with the same status.
        config = Path(self.tmp.name) / "refused.yaml"
        config.write_text(f"group:\n  lcm_url: {LCM_URL}\n  ready_timeout_s: 60\n"
                          "merger:\n  tau: 0\n")
        argv = [sys.executable, str(REPO / "scripts/mfot-run"), "--build-dir", str(BUILD), "--config", str(config),
                "--scenario", "static", "--max-frames", "5", "--workers", "1", "--quiet",
                "--out", str(Path(self.tmp.name) / "run")]
        try:
            res = subprocess.run(argv, capture_output=True, text=True, timeout=45, cwd=self.tmp.name)
        except subprocess.TimeoutExpired:
            self.fail("mfot-run waited for the refusing service instead of stopping")
        output = res.stdout + res.stderr
        self.assertEqual(res.returncode, CONFIG_REFUSED, output)
        self.assertIn("merger refused the configuration: merger.tau", output)
        self.assertIn("before the source starts", output)
        self.assertNotIn("process group up", output)

    def test_shipped_config_is_accepted(self):
        # The control: the same binaries accept configs/default.yaml, so the refusals above are
        # about the bad values and not about how the binaries are run.
        code, output = self.run_service("inprocess", (REPO / "configs/default.yaml").read_text())
        self.assertEqual(code, 0, output)
        self.assertIn("1 frames", output)

    def test_replay_refuses_a_missing_log(self):
        res = subprocess.run([str(BUILD / "services/capture/mfot-capture"), "--config", str(REPO / "configs/default.yaml"),
                              "--source", "lcmlog", "--log", str(Path(self.tmp.name) / "none.lcmlog"), "--lcm-url", LCM_URL],
                             capture_output=True, text=True, timeout=60)
        self.assertNotEqual(res.returncode, 0)
        self.assertIn("none.lcmlog", res.stdout + res.stderr)


if __name__ == "__main__":
    unittest.main()
