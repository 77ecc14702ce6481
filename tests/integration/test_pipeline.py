#!/usr/bin/env python3
"""End-to-end tests of the process group (scripts/mfot-run) over real LCM multicast."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "scripts"))
import mfot_lcm  # noqa: E402
from mfot_script_module import load_script  # noqa: E402

BUILD = Path(os.environ.get("MFOT_BUILD_DIR", REPO / "build"))


def run_group(out: Path, port: int, *args: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, MFOT_LCM_URL=f"udpm://239.255.76.67:{port}?ttl=0")
    cmd = [sys.executable, str(REPO / "scripts/mfot-run"), "--build-dir", str(BUILD), "--out", str(out), "--quiet",
           "--backend", "cpu", *args]
    res = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=1500)
    if res.returncode != 0:
        logs = "".join(f"\n--- {p.name}\n" + p.read_text()[-3000:] for p in sorted((out / "logs").glob("*.log")))
        raise AssertionError(f"mfot-run failed ({res.returncode}):\n{res.stdout[-4000:]}\n{res.stderr[-4000:]}{logs}")
    return res


def results(log: Path, types) -> dict[str, list[bytes]]:
    """The merger's published results in a log, with the publish times and the envelopes' per-process fields
    zeroed."""
    out: dict[str, list[bytes]] = {"MFOT_POSES": [], "MFOT_SEGMENTATION": []}
    for ev in mfot_lcm.read_log(log):
        if ev.channel == "MFOT_POSES":
            msg = types.poses_t.decode(ev.data)
        elif ev.channel == "MFOT_SEGMENTATION":
            msg = types.segmentation_t.decode(ev.data)
        else:
            continue
        msg.utime = 0
        # The envelope names the sending process, its sequence and the MAC: another run's by construction.
        msg.envelope.sender = msg.envelope.sequence = 0
        msg.envelope.mac = [0, 0, 0, 0]
        out[ev.channel].append(msg.encode())
    return out


# The measured figures the tests gate on (the CI floors) live in docs/results/results.json, with the command, date and
# machine of each and the story behind it (docs/results.md, rendered by scripts/gen-results). Each floor is its
# conditions (seed, frames, ground-truth ids, config overrides) and its measured values; the tolerances are the tests'.
RESULTS_JSON = REPO / "docs" / "results" / "results.json"


def load_floors(path: Path = RESULTS_JSON) -> dict[str, object]:
    """The CI floors of the results file by constant name: a scalar as it is, otherwise conditions and values in one
    dict (seed keys of `APART_CONFIRMED` as ints, [median, largest] pairs as tuples)."""
    floors = {}
    for floor in json.loads(path.read_text(encoding="utf-8"))["ci_floors"]:
        values = floor["values"]
        if isinstance(values, dict):
            values = {**floor["conditions"], **values}
        floors[floor["const"]] = values
    floors["APART_CONFIRMED"] = {int(seed): share for seed, share in floors["APART_CONFIRMED"].items()}
    floors["TURNING_BOX_DEG"] = {scenario: tuple(pair) for scenario, pair in floors["TURNING_BOX_DEG"].items()}
    return floors


FLOORS = load_floors()
# Segmentation of the default scenarios (default config, CPU); the gates allow half a point below.
MEASURED_SEGMENTATION = FLOORS["SEGMENTATION"]
# The box the hand grips and turns in `rotate`: median, mean and largest rotation error, degrees.
MEASURED_ROTATED_BOX_MEDIAN_DEG = FLOORS["ROTATED_BOX_MEDIAN_DEG"]
MEASURED_ROTATED_BOX_MEAN_DEG = FLOORS["ROTATED_BOX_MEAN_DEG"]
MEASURED_ROTATED_BOX_MAX_DEG = FLOORS["ROTATED_BOX_MAX_DEG"]
# Hands-free fast turns on the default seeds: the turning box's median and largest rotation error, degrees.
MEASURED_TURNING_BOX_DEG = FLOORS["TURNING_BOX_DEG"]
# `apart` seeds whose first frame joins touching boxes: segmentation of frame 59, by seed.
MEASURED_APART_CONFIRMED = FLOORS["APART_CONFIRMED"]
# `apart` seed 1, frame 39: segmentation with the point-level boundaries between parts, and without.
MEASURED_APART_FLUSH_SEAM = FLOORS["APART_FLUSH_SEAM"]
# `apart` seed 3 whole: a released box splits off alone; the hand's points under other ids.
MEASURED_APART_RELEASED = FLOORS["APART_RELEASED"]
# `apart` seed 1 whole: the low box gripped away while hidden is retired and found again.
MEASURED_APART_GRIPPED_AWAY = FLOORS["APART_GRIPPED_AWAY"]
# `apart` seed 3 up to frame 340: the still base box while an arm withdraws over it.
MEASURED_STILL_BASE_BOX = FLOORS["STILL_BASE_BOX"]
# `stack` seed 36 up to frame 680: the still can behind the stack while an arm creeps over it.
MEASURED_STILL_CAN = FLOORS["STILL_CAN"]
# `rotate` seed 50 up to frame 330 on the moving voxel grid: the box turned quickly from rest.
MEASURED_QUICK_TURN = FLOORS["QUICK_TURN"]
# The same on the defaults' fixed grid with step 5e.
MEASURED_QUICK_TURN_FIXED_GRID = FLOORS["QUICK_TURN_FIXED_GRID"]
# Procedural development seeds 6 and 38: the confidence's ROC AUC against frames over 10 deg.
MEASURED_CONFIDENCE_PROCEDURAL = FLOORS["CONFIDENCE_PROCEDURAL"]
# `apart` learn seed 67, first 40 frames: touching boxes a step apart.
MEASURED_APART_STEP = FLOORS["APART_STEP"]


def run_inprocess(tmp: Path, scenario: str, *args: str, config: Path = REPO / "configs/default.yaml") -> dict:
    """Runs a scenario through mfot-inprocess (CPU) and scores it with mfot-evaluate: the run's evaluation (its
    per-frame rows, mfot-evaluate's frames CSV, under "frames")."""
    out = tmp / "run"
    res = subprocess.run([str(BUILD / "services/inprocess/mfot-inprocess"), "--config", str(config),
                          "--scenario", scenario, "--backend", "cpu", "--out", str(out), *args],
                         capture_output=True, text=True, timeout=900, cwd=REPO)
    if res.returncode != 0:
        raise AssertionError(res.stdout[-4000:] + res.stderr[-4000:])
    ev_out = tmp / "evaluation"
    res = subprocess.run([str(BUILD / "services/evaluate/mfot-evaluate"), "--run", f"mfot={out}", "--groundtruth",
                          str(out / "groundtruth"), "--out", str(ev_out), "--no-plots"],
                         capture_output=True, text=True, timeout=600)
    if res.returncode != 0:
        raise AssertionError(res.stdout[-4000:] + res.stderr[-4000:])
    evaluation = json.loads((ev_out / "summary.json").read_text())["runs"][0]
    with open(ev_out / "mfot_frames.csv", newline="") as f:
        evaluation["frames"] = list(csv.DictReader(f))
    return evaluation


def seeded_object(seed: int, scenario: str, frames: int, groundtruth_id: int, preprocess: dict | None = None,
                  tracker: dict | None = None) -> dict:
    """The evaluation of one ground-truth object over a scenario's first frames at a seed (seeded_config, with the
    preprocess and tracker keys given), its pose errors printed."""
    with tempfile.TemporaryDirectory() as tmp:
        ev = run_inprocess(Path(tmp), scenario, "--max-frames", str(frames),
                           config=seeded_config(Path(tmp), seed, tracker=tracker, preprocess=preprocess))
    found = next(o for o in ev["objects"] if o["groundtruth_id"] == groundtruth_id)
    print(json.dumps(found["pose_error"], indent=1))
    return found


def seeded_config(tmp: Path, seed: int, tracker: dict | None = None, merger: dict | None = None,
                  preprocess: dict | None = None) -> Path:
    """configs/default.yaml with the scene (layout, sensor noise) and the filters drawn from seed, as
    scripts/seed-matrix runs them, and the tracker, merger and preprocess keys given."""
    import yaml
    config = yaml.safe_load((REPO / "configs/default.yaml").read_text())
    config["capture"]["seed"] = seed
    config["tracker"]["seed"] = seed
    config["tracker"].update(tracker or {})
    config["merger"].update(merger or {})
    config["preprocess"].update(preprocess or {})
    path = tmp / f"seed{seed}.yaml"
    path.write_text(yaml.safe_dump(config))
    return path


class PipelineTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.types = mfot_lcm.load_types(os.environ.get("MFOT_LCM_PY_DIR") or str(BUILD / "lcmtypes/python"))

    def test_stack_end_to_end(self):
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "run"
            run_group(out, 7701, "--scenario", "stack")
            summary = json.loads((out / "summary.json").read_text())
            gt_frames = {int(r["frame"]) for r in csv.DictReader(open(out / "groundtruth/poses.csv"))}
            self.assertEqual(summary["frames"], len(gt_frames), "every frame gets a poses message")
            with open(out / "poses.csv") as f:
                rows = list(csv.DictReader(f))
            last = max(int(r["frame"]) for r in rows)
            self.assertEqual(last, max(gt_frames), "poses up to the last frame")
            self.assertTrue(any(p.name.endswith(".png") for p in (out / "labels").iterdir()))
            ev = summary.get("evaluation")
            self.assertIsNotNone(ev, summary.get("evaluation_error"))
            print(json.dumps({k: ev[k] for k in ("segmentation", "pose_error", "tracks_lost")}, indent=1))
            # The three objects on the table at frame 0 are found and tracked from frame 0.
            objects = [o for o in ev["objects"] if not o["is_hand"]]
            self.assertEqual(len(objects), 3)
            for obj in objects:
                self.assertEqual(obj["predicted_first_frame"], 0, obj)
            # Before the hand reaches in, the scene is segmented and tracked accurately.
            with open(out / "evaluation" / "mfot_frames.csv") as f:
                opening = [float(r["accuracy"]) for r in csv.DictReader(f) if int(r["frame"]) < 60]
            self.assertEqual(len(opening), 60)
            self.assertGreater(min(opening), 0.9)
            with open(out / "evaluation" / "mfot_pose_errors.csv") as f:
                early = [r for r in csv.DictReader(f) if int(r["frame"]) < 60]
            self.assertTrue(early)
            self.assertLess(max(float(r["translation_mm"]) for r in early), 10.0)
            # The whole run, hands included: within half a point of the measured figure, nothing lost.
            self.assertGreaterEqual(ev["segmentation"]["accuracy"], MEASURED_SEGMENTATION["stack"] - 0.005)
            self.assertEqual(ev["tracks_lost"], 0)

    def test_contact_accuracy(self):
        """The whole `contact` scenario in process: within half a point of the measured figure, nothing lost."""
        with tempfile.TemporaryDirectory() as tmp:
            ev = run_inprocess(Path(tmp), "contact")
            self.assertGreaterEqual(ev["segmentation"]["accuracy"], MEASURED_SEGMENTATION["contact"] - 0.005)
            self.assertEqual(ev["tracks_lost"], 0)

    def test_rotate_accuracy(self):
        """The whole `rotate` scenario in process (a hand grips a box and turns it about each axis): segmentation
        within half a point of the measured figure, the turned box's median and mean rotation error within a
        quarter degree of it and its largest within two degrees, nothing lost."""
        with tempfile.TemporaryDirectory() as tmp:
            ev = run_inprocess(Path(tmp), "rotate")
            self.assertGreaterEqual(ev["segmentation"]["accuracy"], MEASURED_SEGMENTATION["rotate"] - 0.005)
            self.assertEqual(ev["tracks_lost"], 0)
            box = next(o for o in ev["objects"] if o["groundtruth_id"] == 1)
            self.assertFalse(box["is_hand"])
            self.assertLessEqual(box["pose_error"]["rotation_median_deg"], MEASURED_ROTATED_BOX_MEDIAN_DEG + 0.25)
            self.assertLessEqual(box["pose_error"]["rotation_mean_deg"], MEASURED_ROTATED_BOX_MEAN_DEG + 0.25)
            self.assertLessEqual(box["pose_error"]["rotation_max_deg"], MEASURED_ROTATED_BOX_MAX_DEG + 2.0)

    def test_fast_turns_accuracy(self):
        """`spin` (a box turning at up to 180 deg/s while it slides) and `tumble` (a box tumbling about two axes) in
        process, default seeds: the turning box's median rotation error within a quarter degree of the measured
        figure, its largest within two degrees, nothing lost, every point right."""
        for scenario, (median, largest) in MEASURED_TURNING_BOX_DEG.items():
            with self.subTest(scenario=scenario), tempfile.TemporaryDirectory() as tmp:
                ev = run_inprocess(Path(tmp), scenario)
                self.assertEqual(ev["tracks_lost"], 0)
                self.assertGreaterEqual(ev["segmentation"]["accuracy"], 0.999)
                box = next(o for o in ev["objects"] if o["groundtruth_id"] == 1)
                self.assertFalse(box["symmetric"])
                self.assertLessEqual(box["pose_error"]["rotation_median_deg"], median + 0.25)
                self.assertLessEqual(box["pose_error"]["rotation_max_deg"], largest + 2.0)

    def test_touching_boxes_found_apart(self):
        """`apart`'s first two seconds on seeds whose first frame joins touching boxes into one cluster part: by
        frame 59 the discovery, confirmed over the objects' first frames, has split them: four objects, none lost,
        the frame's segmentation within half a point of the measured figure."""
        for seed, accuracy in MEASURED_APART_CONFIRMED.items():
            with self.subTest(seed=seed), tempfile.TemporaryDirectory() as tmp:
                ev = run_inprocess(Path(tmp), "apart", "--max-frames", "60", config=seeded_config(Path(tmp), seed))
                self.assertEqual(ev["tracks_lost"], 0)
                last = ev["frames"][-1]
                self.assertEqual(int(last["frame"]), 59)
                self.assertEqual(int(last["predicted_objects"]), 4)
                self.assertGreaterEqual(float(last["accuracy"]), accuracy - 0.005)

    def test_flush_faces_drawn_apart(self):
        """`apart` seed 1's first 40 frames: with the point-level boundaries between discovered parts, frame 39's
        segmentation is within half a point of the measured figure, and above the figure measured without them
        (boundary radius 0, when it was an option)."""
        seam = MEASURED_APART_FLUSH_SEAM
        with tempfile.TemporaryDirectory() as tmp:
            config = seeded_config(Path(tmp), seam["seed"])
            ev = run_inprocess(Path(tmp), "apart", "--max-frames", str(seam["frame"] + 1), config=config)
            last = ev["frames"][-1]
            self.assertEqual(int(last["frame"]), seam["frame"])
            self.assertEqual(int(last["predicted_objects"]), 4)
            self.assertGreaterEqual(float(last["accuracy"]), seam["accuracy"] - 0.005)
            self.assertGreater(float(last["accuracy"]), seam["without"] + 0.005)

    def test_a_released_box_splits_off_alone(self):
        """`apart` seed 3 whole: the hand that puts the low box down keeps its front (no part of it under another
        id beyond a tenth of a point of the scene), no object is lost, and the run's segmentation is within 0.1 point
        of the measured figure."""
        released = MEASURED_APART_RELEASED
        with tempfile.TemporaryDirectory() as tmp:
            ev = run_inprocess(Path(tmp), "apart", config=seeded_config(Path(tmp), released["seed"]))
            self.assertEqual(ev["tracks_lost"], 0)
            self.assertGreaterEqual(ev["segmentation"]["accuracy"], released["segmentation"] - 0.001)
            with open(Path(tmp) / "evaluation" / "mfot_segments.csv", newline="") as f:
                elsewhere = sum(float(row["share_of_points"]) for row in csv.DictReader(f)
                                if int(row["groundtruth_id"]) == released["hand"]
                                and int(row["mapped_groundtruth_id"]) != released["hand"])
            self.assertLessEqual(elsewhere, released["hand_elsewhere"] + 0.001)

    def test_a_box_gripped_away_while_hidden_is_retired(self):
        """`apart` seed 1 whole with the defaults: the low box, hidden behind the hand before the hand grips and lifts
        it, is retired once its place is seen through and found again (not lost); where it is published it is within
        2 deg and 10 mm of the measured largest errors (24.1 deg and 210.6 mm when it waited where it was held), it is
        without an estimate for at most 10 frames more than measured, and the run's segmentation is within 0.1
        point of the measured figure."""
        gone = MEASURED_APART_GRIPPED_AWAY
        with tempfile.TemporaryDirectory() as tmp:
            ev = run_inprocess(Path(tmp), "apart", config=seeded_config(Path(tmp), gone["seed"]))
            self.assertEqual(ev["tracks_lost"], 0)
            self.assertGreaterEqual(ev["segmentation"]["accuracy"], gone["segmentation"] - 0.001)
            box = next(o for o in ev["objects"] if o["groundtruth_id"] == gone["low_box"])
            frames = box["groundtruth_last_frame"] - box["groundtruth_first_frame"] + 1
            self.assertLessEqual(frames - box["compared_frames"], gone["unestimated_frames"] + 10)
            self.assertLessEqual(box["pose_error"]["rotation_max_deg"], gone["rotation_max_deg"] + 2)
            self.assertLessEqual(box["pose_error"]["translation_max_mm"], gone["translation_max_mm"] + 10)

    def test_touching_boxes_a_step_apart_are_found_apart(self):
        """`apart` seed 67's first 40 frames with the defaults: the low box, joined to the tall box at birth, is split
        off by the confirmation (no object lost) and the segmentation is within 0.1 point of the measured figure
        (85.35 % and a box lost with 3 cm supervoxels, so the test fails with them)."""
        step = MEASURED_APART_STEP
        with tempfile.TemporaryDirectory() as tmp:
            ev = run_inprocess(Path(tmp), "apart", "--max-frames", str(step["frames"]),
                               config=seeded_config(Path(tmp), step["seed"]))
            print(json.dumps({k: ev[k] for k in ("segmentation", "tracks_lost")}, indent=1))
            self.assertEqual(ev["tracks_lost"], 0)
            self.assertGreaterEqual(ev["segmentation"]["accuracy"], step["segmentation"] - 0.001)

    def test_a_still_box_stays_put_under_an_arm(self):
        """`apart` seed 3 up to frame 340: the base box, still while an arm withdraws over it and hides up to half of
        it, stays within 1 deg and 2 mm of the measured largest errors (8.2 deg and 13.7 mm without the last pose
        check, so the test fails without it)."""
        still = MEASURED_STILL_BASE_BOX
        box = seeded_object(still["seed"], "apart", still["frames"], still["box"])
        self.assertFalse(box["lost"])
        self.assertLessEqual(box["pose_error"]["rotation_max_deg"], still["rotation_max_deg"] + 1)
        self.assertLessEqual(box["pose_error"]["translation_max_mm"], still["translation_max_mm"] + 2)

    def test_a_still_can_stays_put_past_a_creeping_arm(self):
        """`stack` seed 36 up to frame 680: the can behind the stack, which the arm lifting the top box creeps over
        (within the carry window's tolerance) and hides, is not carried off by that arm: its largest errors within 2 mm
        and 1 deg of the measured (65.8 mm and 22.7 deg with the old carry rule, so the test fails without it)."""
        still = MEASURED_STILL_CAN
        can = seeded_object(still["seed"], "stack", still["frames"], still["can"])
        self.assertFalse(can["lost"])
        self.assertTrue(can["symmetric"])
        self.assertLessEqual(can["pose_error"]["translation_max_mm"], still["translation_max_mm"] + 2)
        self.assertLessEqual(can["pose_error"]["observable_rotation_max_deg"], still["observable_rotation_max_deg"] + 1)

    def test_a_box_turned_quickly_from_rest_is_followed(self):
        """`rotate` seed 50 up to frame 330 with a voxel grid drawn per frame: the box the hand starts turning at frame
        304 is followed through the turn, its largest rotation error within a degree of the measured (14.0 deg on the
        defaults' fixed grid, so the test fails without the moving grid)."""
        turn = MEASURED_QUICK_TURN
        box = seeded_object(turn["seed"], "rotate", turn["frames"], turn["box"], preprocess=turn["preprocess"])
        self.assertFalse(box["lost"])
        self.assertFalse(box["symmetric"])
        self.assertLessEqual(box["pose_error"]["rotation_max_deg"], turn["rotation_max_deg"] + 1)

    def test_a_box_turned_quickly_from_rest_is_followed_on_the_fixed_grid(self):
        """The same turn on the defaults' fixed grid: the gripped box keeps the filter's turn where the hand turns the same
        way and ICP turned it back, so its largest rotation error is within a degree of the measured one (with that
        step off it was 13.97 deg, measured before step 5e's switch became a constant of the method)."""
        turn = MEASURED_QUICK_TURN_FIXED_GRID
        box = seeded_object(turn["seed"], "rotate", turn["frames"], turn["box"])
        self.assertFalse(box["lost"])
        self.assertLessEqual(box["pose_error"]["rotation_max_deg"], turn["rotation_max_deg"] + 1)

    def test_the_confidence_tells_the_wrong_frames(self):
        """Procedural development seeds 6 and 38 with the shipped config, whose moved object is over 10 deg off in many
        frames (at least half the measured count, their frames pooled): the ROC AUC of the published confidence
        against those frames is within 0.03 of the measured one (docs/results/results.json, ci_floors
        "confidence_procedural")."""
        want = MEASURED_CONFIDENCE_PROCEDURAL
        matrix = load_script(REPO / "scripts/seed-matrix", "seed_matrix")  # its ROC of the confidence
        pairs = []
        for seed in want["seeds"]:
            with tempfile.TemporaryDirectory() as tmp:
                ev = run_inprocess(Path(tmp), want["scenario"], config=seeded_config(Path(tmp), seed))
                hands = {o["groundtruth_id"] for o in ev["objects"] if o["is_hand"]}
                pairs += matrix.confidence_pairs(Path(tmp) / "run" / "poses.csv",
                                                 Path(tmp) / "evaluation" / "mfot_pose_errors.csv", hands)
        wrong = sum(1 for _, is_wrong in pairs if is_wrong)
        auc = matrix.roc_auc(pairs)
        print(json.dumps({"frames": len(pairs), "wrong": wrong, "auc": auc}))
        self.assertGreaterEqual(wrong, want["wrong_frames"] // 2)  # else the AUC would say little
        self.assertGreaterEqual(auc, want["auc"] - 0.03)

    def test_inprocess_static_scene(self):
        """The in-process pipeline (no LCM) finds and holds the three objects of the static scene."""
        with tempfile.TemporaryDirectory() as tmp:
            ev = run_inprocess(Path(tmp), "static", "--max-frames", "60")
            self.assertEqual(ev["tracks_lost"], 0)
            self.assertGreater(ev["segmentation"]["accuracy"], 0.9)
            self.assertLess(ev["pose_error"]["translation_median_mm"], 5.0)

    def test_bundled_group_runs(self):
        """scripts/bundle makes a folder mfot-run takes as its build dir: services, lcm-logger, Python types."""
        with tempfile.TemporaryDirectory() as tmp:
            bundle = Path(tmp) / "bundle"
            res = subprocess.run([str(REPO / "scripts/bundle"), str(BUILD), str(bundle)], capture_output=True, text=True,
                                 timeout=300)
            self.assertEqual(res.returncode, 0, res.stdout + res.stderr)
            for service in ("capture", "preprocess", "tracker", "merger"):
                self.assertTrue((bundle / "services" / service / f"mfot-{service}").is_file(), service)
            self.assertTrue((bundle / "bin/lcm-logger").is_file())
            self.assertTrue(any((bundle / "lib").glob("liblcm.so*")))
            env = {k: v for k, v in os.environ.items() if k != "MFOT_LCM_PY_DIR"}
            env.update(MFOT_LCM_URL="udpm://239.255.76.67:7704?ttl=0", LD_LIBRARY_PATH=str(bundle / "lib"),
                       PATH=f"{bundle / 'bin'}:{os.environ['PATH']}")
            out = Path(tmp) / "run"
            res = subprocess.run([sys.executable, str(REPO / "scripts/mfot-run"), "--build-dir", str(bundle), "--out",
                                  str(out), "--quiet", "--backend", "cpu", "--scenario", "static", "--max-frames", "20"],
                                 env=env, capture_output=True, text=True, timeout=600)
            self.assertEqual(res.returncode, 0, res.stdout[-3000:] + res.stderr[-3000:])
            with open(out / "poses.csv") as f:
                frames = {int(row["frame"]) for row in csv.DictReader(f)}
            self.assertEqual(frames, set(range(20)))
            self.assertGreater((out / "mfot.lcmlog").stat().st_size, 0)

    def test_lockstep_replay_is_bit_identical(self):
        with tempfile.TemporaryDirectory() as tmp:
            first = Path(tmp) / "record"
            run_group(first, 7702, "--scenario", "contact", "--max-frames", "90")
            second = Path(tmp) / "replay"
            run_group(second, 7703, "--replay", str(first / "mfot.lcmlog"))
            a = results(first / "mfot.lcmlog", self.types)
            b = results(second / "mfot.lcmlog", self.types)
            for channel in a:
                self.assertGreater(len(a[channel]), 80, channel)
                self.assertEqual(len(a[channel]), len(b[channel]), channel)
                for k, (x, y) in enumerate(zip(a[channel], b[channel])):
                    self.assertEqual(x, y, f"{channel} message {k} differs between recording and replay")

    def test_lockstep_window_is_bit_identical(self):
        """A lockstep window of several frames (the next frames preprocessed while the trackers and
        the merger work on earlier ones) gives byte for byte the results of one frame at a time."""
        with tempfile.TemporaryDirectory() as tmp:
            serial = Path(tmp) / "window1"
            run_group(serial, 7705, "--scenario", "contact", "--max-frames", "90", "--lockstep-window", "1")
            windowed = Path(tmp) / "window4"
            run_group(windowed, 7706, "--replay", str(serial / "mfot.lcmlog"), "--lockstep-window", "4")
            a = results(serial / "mfot.lcmlog", self.types)
            b = results(windowed / "mfot.lcmlog", self.types)
            for channel in a:
                self.assertEqual(len(a[channel]), 90, channel)
                self.assertEqual(len(a[channel]), len(b[channel]), channel)
                for k, (x, y) in enumerate(zip(a[channel], b[channel])):
                    self.assertEqual(x, y, f"{channel} message {k} differs between window 1 and window 4")
            for name in ("poses.csv", "fitting.csv"):
                self.assertEqual((serial / name).read_bytes(), (windowed / name).read_bytes(), name)
            labels = sorted(p.name for p in (serial / "labels").iterdir())
            self.assertEqual(len(labels), 90)
            self.assertEqual(labels, sorted(p.name for p in (windowed / "labels").iterdir()))
            for name in labels:
                self.assertEqual((serial / "labels" / name).read_bytes(), (windowed / "labels" / name).read_bytes(),
                                 f"labels/{name}")
            # The window was used: the replay had more than one frame out at a time.
            frames_ahead = 0
            waiting: set[int] = set()
            for ev in mfot_lcm.read_log(windowed / "mfot.lcmlog"):
                if ev.channel == "MFOT_FRAME":
                    waiting.add(self.types.frame_t.decode(ev.data).seq)
                    frames_ahead = max(frames_ahead, len(waiting))
                elif ev.channel == "MFOT_POSES":
                    waiting.discard(self.types.poses_t.decode(ev.data).frame_seq)
            self.assertGreater(frames_ahead, 1, "the replay never had two frames without poses")


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1] + sys.argv[1:], verbosity=2)
