#!/usr/bin/env python3
"""End-to-end tests of the process group (scripts/mfot-run) over real LCM multicast."""

from __future__ import annotations

import csv
import json
import os
import struct
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
    """The merger's published results in a log, with the publish times zeroed."""
    out: dict[str, list[bytes]] = {"MFOT_POSES": [], "MFOT_SEGMENTATION": []}
    for ev in mfot_lcm.read_log(log):
        if ev.channel == "MFOT_POSES":
            msg = types.poses_t.decode(ev.data)
        elif ev.channel == "MFOT_SEGMENTATION":
            msg = types.segmentation_t.decode(ev.data)
        else:
            continue
        msg.utime = 0
        out[ev.channel].append(msg.encode())
    return out


# Segmentation accuracy of the default scenarios in the README's accuracy table (default config, CPU); the
# CI gates allow half a point below them.
README_SEGMENTATION = {"stack": 0.9968, "contact": 0.9970, "rotate": 0.9988}
# The median rotation error of the box the hand grips and turns in `rotate` (README "Measured": 0.27 deg with ICP on
# 2000 points, 0.45 deg with the box predicted with the hand's motion, 0.52 deg with every estimate refined on the
# model's surface and the box carried with the hand while hidden, 1.4 deg with isolated objects alone refined, 11 deg
# on scene seed 3 before the trackers left the points other objects claim out).
README_ROTATED_BOX_MEDIAN_DEG = 0.27
# ... and its mean and largest, which the frames hidden behind the hand dominate (1.08 / 6.8 deg with ICP anchored on
# the first view; 1.00 / 6.2 deg with ICP on 2000 points before: the hand that carries it is followed in roll;
# 1.68 / 19.5 deg on 200 points, 1.72 / 19.5 with the carry watch over a sliding window, 3.26 / 31.5 deg with the
# companion's motion and the hold at 20 %, 3.07 / 30.8 deg carried with the hand, 3.61 deg when it waited where it
# was last seen).
README_ROTATED_BOX_MEAN_DEG = 1.08
README_ROTATED_BOX_MAX_DEG = 6.8
# Hands-free fast turns on the default seeds (README "Seed matrix with isolated objects followed harder"): the
# turning box's median and largest rotation error, degrees, with grown parts re-fitted on the first view (README "Grown
# parts re-fitted on the first view"; without: spin 0.83 / 4.3, tumble 1.55 / 10.4) and ICP anchored on the first view
# (README "Anchored on the first view"; with every model point alike spin 0.99 / 3.5 and tumble 1.47 / 6.4; ICP on 200
# points: spin 1.38 / 4.6, tumble 1.93 / 7.1; with tracker.follow_isolated: false, the thesis's motion model, spin
# reads 4.58 / 18.1 and tumble 3.50 / 14.0).
README_TURNING_BOX_DEG = {"spin": (0.74, 6.0), "tumble": (1.13, 8.2)}
# `apart` seeds whose first frame's sensor noise joins touching boxes (README "Objects found apart from the first
# frame"): segmentation of frame 59, after the discovery confirmed over the first frames split them (without it
# 85.14 % and 64.56 %, three and two objects).
README_APART_CONFIRMED = {3: 0.9812, 5: 0.9816}
# `apart` seed 1, frame 39 (README "Point-level boundaries between discovered parts"): the low box's front face, 5 mm
# behind the tall box's, no longer leaves a strip in the tall box (97.37 % with merger.discovery.boundary_radius 0).
README_APART_FLUSH_SEAM = {"seed": 1, "frame": 39, "accuracy": 0.9899, "without": 0.9737}
# `apart` seed 3 whole (README "A part splits off once it departs from the object's motion"): when the hand lets go of
# the low box its points lie in three clusters (arm, front, box); only the box splits off. Segmentation 99.41 % with
# grown parts re-fitted on the first view (README "Grown parts re-fitted on the first view"; 99.54 % before, the box
# gripped away retired; 99.42 % when it waited where it was held; 98.99 % when every part split off), the hand's
# points under other ids 0.03 % of the scene's (0.54 %).
README_APART_RELEASED = {"seed": 3, "segmentation": 0.9941, "hand": 101, "hand_elsewhere": 0.0003}
# `apart` seed 1 whole with merger.carry.gripped_away: carry (README "A box gripped while hidden, carried once its
# place is seen through"; retire is the default): the low box the hand covers before it grips and lifts it is carried
# once its place is seen through. Segmentation 99.62 % since the box brought back is found again by registration
# (README "Touching boxes a step apart"; 99.03 % before; 98.41 % when it waits where it was held, retires and is found
# again), the low box (ground-truth id 4) estimated in every frame (60 frames without an estimate when it waits) and at
# most 72.8 mm off (74.3 before; 212.8 mm when it waits; 45.5 mm before ICP was anchored on the first view: the carried
# box follows the hand's estimate).
README_APART_CARRIED = {"seed": 1, "gripped_away": "carry", "segmentation": 0.9962, "low_box": 4,
                        "translation_max_mm": 72.8}
# The same with the defaults (README "A box gripped away while hidden is retired"): the low box is retired once its place
# is seen through and found again where the hand puts it down. Segmentation 99.54 %, the low box at most 3.4 deg and
# 60.5 mm off where published, 93 frames without an estimate (dev machine, 2026-11-27: 99.55 %, 3.5 deg, 44.5 mm, 93
# frames; 86 frames at an earlier stop; 5.6 deg, 45.6 mm and 93 frames before the last pose check, README "A partly
# hidden object kept where it was": held where it was while the hand lifts it, it is retired 7 frames later; 24.1 deg
# and 210.6 mm when it waited where it was held).
README_APART_GRIPPED_AWAY = {"seed": 1, "segmentation": 0.9954, "low_box": 4, "rotation_max_deg": 3.4,
                             "translation_max_mm": 60.5, "unestimated_frames": 93}

# `apart` seed 3 up to frame 340 (README "A partly hidden object kept where it was"): the base box (ground-truth id 2)
# never moves; while the arm that put the top box down withdraws over it (frames 299-325) its largest rotation and
# translation errors, degrees and mm, with the last pose check (8.2 deg and 13.7 mm without: the JCSD's mode sinks its
# visible surface into its hidden side).
README_STILL_BASE_BOX = {"seed": 3, "frames": 340, "box": 2, "rotation_max_deg": 1.6,
                         "translation_max_mm": 4.8}
# README "Measured", "Carried only what moved": `stack` seed 36 up to frame 680, the can behind the stack (ground truth
# 3, symmetric), still while the arm that lifts the top box creeps over it and hides it: its largest translation and
# observable rotation errors, mm and degrees (65.8 mm and 22.7 deg when a neighbour that never moved it carried it).
README_STILL_CAN = {"seed": 36, "frames": 680, "can": 3, "translation_max_mm": 7.6, "observable_rotation_max_deg": 2.8}
# README "Measured", "A voxel grid that moves every frame": `rotate` seed 50 up to frame 330 with preprocess.voxel_jitter,
# the box (ground truth 1) that the hand turns from rest at up to 2.5 deg a frame over frames 304-316: its largest
# rotation error, degrees (14.0 on the fixed grid of the defaults, where ICP held it at the pose its model was sampled
# at through frames 307-313).
README_QUICK_TURN = {"seed": 50, "frames": 330, "box": 1, "rotation_max_deg": 5.5,
                     "preprocess": {"voxel_jitter": True}}
# README "Measured", "A turn the filter and the companion agree on": the same box and frames on the defaults' fixed grid,
# where step 5e keeps the filter's turn that the hand's turn agrees with and ICP turned back: its largest rotation
# error, degrees, and that with the step off (tracker.companion_turn_min_deg: 0; ICP held the box where it was).
README_QUICK_TURN_FIXED_GRID = {"seed": 50, "frames": 330, "box": 1, "rotation_max_deg": 3.49, "off_max_deg": 13.97}
# README "Measured", "Confidence that sees through a wrong estimate": `rotate` seed 4 with ICP and the companion pose
# check off (measured before the check was on), the particles left where the filter's step put them (measured before
# tracker.particles_follow_refinement, with which the last pose check alone keeps all but 7 frames within 10 deg) and
# labels propagated into thinly seeded clusters (measured before merger.propagation_min_seed_share 0.1, with which
# only 27 of its frames are over 10 deg), the confidence's ROC AUC against its frames over 10 deg (0.664 with
# tracker.confidence_seen_through_weight: 0).
README_CONFIDENCE_ROTATE = {"seed": 4, "tracker": {"icp_iterations": 0, "companion_pose_check": False,
                                                   "particles_follow_refinement": 0.0},
                           "merger": {"propagation_min_seed_share": 0}, "auc": 0.882, "wrong_frames": 375}
# README "Measured", "Touching boxes a step apart": `apart` learn seed 67's first 40 frames, whose birth joined the low box
# and the tall box it stands against (its front face 1 cm behind); 2 cm supervoxels let the confirmation split them.
# Segmentation over those frames (85.35 % and a box lost with 3 cm supervoxels, merger.discovery.seed_resolution 0.03).
README_APART_STEP = {"seed": 67, "frames": 40, "segmentation": 0.9915}


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


def seeded_config(tmp: Path, seed: int, gripped_away: str | None = None, tracker: dict | None = None,
                  merger: dict | None = None, preprocess: dict | None = None) -> Path:
    """configs/default.yaml with the scene (layout, sensor noise) and the filters drawn from seed, as
    scripts/seed-matrix runs them (and merger.carry.gripped_away when given; `carry` as configs/carry.yaml lays it
    over the defaults, with the tracker settings it needs), and the tracker, merger and preprocess keys given."""
    import yaml
    config = yaml.safe_load((REPO / "configs/default.yaml").read_text())
    config["capture"]["seed"] = seed
    config["tracker"]["seed"] = seed
    config["tracker"].update(tracker or {})
    config["merger"].update(merger or {})
    config["preprocess"].update(preprocess or {})
    if gripped_away is not None:
        config["merger"]["carry"]["gripped_away"] = gripped_away
        if gripped_away == "carry":
            carry = yaml.safe_load((REPO / "configs/carry.yaml").read_text())
            config["merger"]["carry"].update(carry["merger"]["carry"])
            config["tracker"].update(carry["tracker"])
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
            # The whole run, hands included: within half a point of the README's figure, nothing lost.
            self.assertGreaterEqual(ev["segmentation"]["accuracy"], README_SEGMENTATION["stack"] - 0.005)
            self.assertEqual(ev["tracks_lost"], 0)

    def test_contact_accuracy(self):
        """The whole `contact` scenario in process: within half a point of the README's figure, nothing lost."""
        with tempfile.TemporaryDirectory() as tmp:
            ev = run_inprocess(Path(tmp), "contact")
            self.assertGreaterEqual(ev["segmentation"]["accuracy"], README_SEGMENTATION["contact"] - 0.005)
            self.assertEqual(ev["tracks_lost"], 0)

    def test_rotate_accuracy(self):
        """The whole `rotate` scenario in process (a hand grips a box and turns it about each axis): segmentation
        within half a point of the README's figure, the turned box's median and mean rotation error within a quarter
        degree of it and its largest within two degrees, nothing lost."""
        with tempfile.TemporaryDirectory() as tmp:
            ev = run_inprocess(Path(tmp), "rotate")
            self.assertGreaterEqual(ev["segmentation"]["accuracy"], README_SEGMENTATION["rotate"] - 0.005)
            self.assertEqual(ev["tracks_lost"], 0)
            box = next(o for o in ev["objects"] if o["groundtruth_id"] == 1)
            self.assertFalse(box["is_hand"])
            self.assertLessEqual(box["pose_error"]["rotation_median_deg"], README_ROTATED_BOX_MEDIAN_DEG + 0.25)
            self.assertLessEqual(box["pose_error"]["rotation_mean_deg"], README_ROTATED_BOX_MEAN_DEG + 0.25)
            self.assertLessEqual(box["pose_error"]["rotation_max_deg"], README_ROTATED_BOX_MAX_DEG + 2.0)

    def test_fast_turns_accuracy(self):
        """`spin` (a box turning at up to 180 deg/s while it slides) and `tumble` (a box tumbling about two axes) in
        process, default seeds: the turning box's median rotation error within a quarter degree of the README's
        figure, its largest within two degrees, nothing lost, every point right."""
        for scenario, (median, largest) in README_TURNING_BOX_DEG.items():
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
        the frame's segmentation within half a point of the README's figure."""
        for seed, accuracy in README_APART_CONFIRMED.items():
            with self.subTest(seed=seed), tempfile.TemporaryDirectory() as tmp:
                ev = run_inprocess(Path(tmp), "apart", "--max-frames", "60", config=seeded_config(Path(tmp), seed))
                self.assertEqual(ev["tracks_lost"], 0)
                last = ev["frames"][-1]
                self.assertEqual(int(last["frame"]), 59)
                self.assertEqual(int(last["predicted_objects"]), 4)
                self.assertGreaterEqual(float(last["accuracy"]), accuracy - 0.005)

    def test_flush_faces_drawn_apart(self):
        """`apart` seed 1's first 40 frames: with the point-level boundaries between discovered parts, frame 39's
        segmentation is within half a point of the README's figure, and above the figure without them."""
        import yaml
        seam = README_APART_FLUSH_SEAM
        with tempfile.TemporaryDirectory() as tmp:
            config = seeded_config(Path(tmp), seam["seed"])
            ev = run_inprocess(Path(tmp), "apart", "--max-frames", str(seam["frame"] + 1), config=config)
            last = ev["frames"][-1]
            self.assertEqual(int(last["frame"]), seam["frame"])
            self.assertEqual(int(last["predicted_objects"]), 4)
            self.assertGreaterEqual(float(last["accuracy"]), seam["accuracy"] - 0.005)
            self.assertGreater(float(last["accuracy"]), seam["without"] + 0.005)
        with tempfile.TemporaryDirectory() as tmp:
            off = yaml.safe_load(seeded_config(Path(tmp), seam["seed"]).read_text())
            off["merger"]["discovery"]["boundary_radius"] = 0
            path = Path(tmp) / "off.yaml"
            path.write_text(yaml.safe_dump(off))
            ev = run_inprocess(Path(tmp), "apart", "--max-frames", str(seam["frame"] + 1), config=path)
            self.assertAlmostEqual(float(ev["frames"][-1]["accuracy"]), seam["without"], delta=0.005)

    def test_a_released_box_splits_off_alone(self):
        """`apart` seed 3 whole: the hand that puts the low box down keeps its front (no part of it under another
        id beyond a tenth of a point of the scene), no object is lost, and the run's segmentation is within 0.1 point
        of the README's figure."""
        released = README_APART_RELEASED
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
        2 deg and 10 mm of the README's largest errors (24.1 deg and 210.6 mm when it waited where it was held), it is
        without an estimate for at most 10 frames more than the README says, and the run's segmentation is within 0.1
        point of the README's figure."""
        gone = README_APART_GRIPPED_AWAY
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
        off by the confirmation (no object lost) and the segmentation is within 0.1 point of the README's figure
        (85.35 % and a box lost with 3 cm supervoxels, so the test fails with them)."""
        step = README_APART_STEP
        with tempfile.TemporaryDirectory() as tmp:
            ev = run_inprocess(Path(tmp), "apart", "--max-frames", str(step["frames"]),
                               config=seeded_config(Path(tmp), step["seed"]))
            print(json.dumps({k: ev[k] for k in ("segmentation", "tracks_lost")}, indent=1))
            self.assertEqual(ev["tracks_lost"], 0)
            self.assertGreaterEqual(ev["segmentation"]["accuracy"], step["segmentation"] - 0.001)

    def test_a_still_box_stays_put_under_an_arm(self):
        """`apart` seed 3 up to frame 340: the base box, still while an arm withdraws over it and hides up to half of
        it, stays within 1 deg and 2 mm of the README's largest errors (8.2 deg and 13.7 mm without the last pose
        check, so the test fails without it)."""
        still = README_STILL_BASE_BOX
        box = seeded_object(still["seed"], "apart", still["frames"], still["box"])
        self.assertFalse(box["lost"])
        self.assertLessEqual(box["pose_error"]["rotation_max_deg"], still["rotation_max_deg"] + 1)
        self.assertLessEqual(box["pose_error"]["translation_max_mm"], still["translation_max_mm"] + 2)

    def test_a_still_can_stays_put_past_a_creeping_arm(self):
        """`stack` seed 36 up to frame 680: the can behind the stack, which the arm lifting the top box creeps over
        (within the carry window's tolerance) and hides, is not carried off by that arm: its largest errors within 2 mm
        and 1 deg of the README's (65.8 mm and 22.7 deg with the old carry rule, so the test fails without it)."""
        still = README_STILL_CAN
        can = seeded_object(still["seed"], "stack", still["frames"], still["can"])
        self.assertFalse(can["lost"])
        self.assertTrue(can["symmetric"])
        self.assertLessEqual(can["pose_error"]["translation_max_mm"], still["translation_max_mm"] + 2)
        self.assertLessEqual(can["pose_error"]["observable_rotation_max_deg"], still["observable_rotation_max_deg"] + 1)

    def test_a_box_turned_quickly_from_rest_is_followed(self):
        """`rotate` seed 50 up to frame 330 with a voxel grid drawn per frame: the box the hand starts turning at frame
        304 is followed through the turn, its largest rotation error within a degree of the README's (14.0 deg on the
        defaults' fixed grid, so the test fails without the moving grid)."""
        turn = README_QUICK_TURN
        box = seeded_object(turn["seed"], "rotate", turn["frames"], turn["box"], preprocess=turn["preprocess"])
        self.assertFalse(box["lost"])
        self.assertFalse(box["symmetric"])
        self.assertLessEqual(box["pose_error"]["rotation_max_deg"], turn["rotation_max_deg"] + 1)

    def test_a_box_turned_quickly_from_rest_is_followed_on_the_fixed_grid(self):
        """The same turn on the defaults' fixed grid: the gripped box keeps the filter's turn where the hand turns the same
        way and ICP turned it back, so its largest rotation error is within a degree of the README's 3.49 deg; with that
        step off it is over 10 deg (13.97 in the README), so the test fails without the step."""
        turn = README_QUICK_TURN_FIXED_GRID
        box = seeded_object(turn["seed"], "rotate", turn["frames"], turn["box"])
        self.assertFalse(box["lost"])
        self.assertLessEqual(box["pose_error"]["rotation_max_deg"], turn["rotation_max_deg"] + 1)
        held = seeded_object(turn["seed"], "rotate", turn["frames"], turn["box"], tracker={"companion_turn_min_deg": 0})
        self.assertGreater(held["pose_error"]["rotation_max_deg"], 10)
        self.assertLessEqual(held["pose_error"]["rotation_max_deg"], turn["off_max_deg"] + 1)

    def test_the_confidence_tells_the_wrong_frames(self):
        """`rotate` seed 4 with ICP off (and the companion pose check, which without ICP still keeps the gripped box
        where the hand takes it, the particles following the last pose check, and the propagation guard), so that its
        gripped box is over 10 deg off in hundreds of frames: the ROC AUC of the published confidence against those
        frames is within 0.03 of the README's 0.882 (0.664 from the fit alone, so the test fails without the
        seen-through share)."""
        want = README_CONFIDENCE_ROTATE
        matrix = load_script(REPO / "scripts/seed-matrix", "seed_matrix")  # its ROC of the confidence
        with tempfile.TemporaryDirectory() as tmp:
            ev = run_inprocess(Path(tmp), "rotate", config=seeded_config(Path(tmp), want["seed"], tracker=want["tracker"],
                                                                        merger=want["merger"]))
            hands = {o["groundtruth_id"] for o in ev["objects"] if o["is_hand"]}
            pairs = matrix.confidence_pairs(Path(tmp) / "run" / "poses.csv",
                                            Path(tmp) / "evaluation" / "mfot_pose_errors.csv", hands)
            wrong = sum(1 for _, is_wrong in pairs if is_wrong)
            auc = matrix.roc_auc(pairs)
            print(json.dumps({"frames": len(pairs), "wrong": wrong, "auc": auc}))
            self.assertGreaterEqual(wrong, want["wrong_frames"] // 2)  # else the AUC would say little
            self.assertGreaterEqual(auc, want["auc"] - 0.03)

    def test_a_box_gripped_while_hidden_is_carried(self):
        """`apart` seed 1 whole with merger.carry.gripped_away: carry: the low box, hidden behind the hand before the
        hand grips and lifts it, is estimated in every frame (carried, not retired), within 10 mm of the README's
        largest translation error, and the run's segmentation is within 0.1 point of the README's figure."""
        with tempfile.TemporaryDirectory() as tmp:
            config = seeded_config(Path(tmp), README_APART_CARRIED["seed"], README_APART_CARRIED["gripped_away"])
            ev = run_inprocess(Path(tmp), "apart", config=config)
            print(json.dumps({k: ev[k] for k in ("segmentation", "pose_error", "tracks_lost")}, indent=1))
            self.assertGreaterEqual(ev["segmentation"]["accuracy"], README_APART_CARRIED["segmentation"] - 0.001)
            box = next(o for o in ev["objects"] if o["groundtruth_id"] == README_APART_CARRIED["low_box"])
            self.assertFalse(box["lost"])
            self.assertEqual(box["compared_frames"], box["groundtruth_last_frame"] - box["groundtruth_first_frame"] + 1)
            self.assertLessEqual(box["pose_error"]["translation_max_mm"], README_APART_CARRIED["translation_max_mm"] + 10)

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
                    waiting.add(struct.unpack_from(">q", ev.data, 24)[0])  # frame_t.seq after fingerprint, utimes
                    frames_ahead = max(frames_ahead, len(waiting))
                elif ev.channel == "MFOT_POSES":
                    waiting.discard(self.types.poses_t.decode(ev.data).frame_seq)
            self.assertGreater(frames_ahead, 1, "the replay never had two frames without poses")


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1] + sys.argv[1:], verbosity=2)
