"""Fitting distance of the rigid objects of a run, for scripts/bench-baselines and
scripts/particle-sweep.

mfot-evaluate averages fitting.csv over every tracked object. mfot also tracks the hands (they are
objects to it, thesis 3.1), and a hand with its arm is not rigid, so its fitting distance (1-2 cm)
would swamp the objects' (1-2 mm) and penalise a method for tracking hands at all; PCL's baseline
never tracks them. The comparison therefore averages over the predicted objects that mfot-evaluate
maps to a ground-truth object that is not a hand, like the thesis's figures of its boxes.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path


def rigid_object_ids(run_summary: dict) -> set[int]:
    """Predicted ids mapped to a ground-truth object that is not a hand (summary.json run entry)."""
    hands = {o["groundtruth_id"] for o in run_summary["objects"] if o["is_hand"]}
    return {int(pred) for pred, gt in run_summary["segmentation"]["mapping"].items()
            if gt is not None and gt > 0 and gt not in hands}


def rigid_fitting_by_frame(run_dir: Path, run_summary: dict) -> dict[int, float]:
    """Frame -> mean fitting distance (metres) over the run's rigid objects listed that frame."""
    ids = rigid_object_ids(run_summary)
    sums: dict[int, list[float]] = {}
    with open(Path(run_dir) / "fitting.csv", newline="") as f:
        for row in csv.DictReader(f):
            if int(row["object_id"]) in ids:
                value = float(row["fitting_distance_m"])
                if math.isfinite(value):
                    sums.setdefault(int(row["frame"]), []).append(value)
    return {frame: sum(values) / len(values) for frame, values in sums.items()}


def mean(values) -> float:
    values = list(values)
    return sum(values) / len(values) if values else math.nan
