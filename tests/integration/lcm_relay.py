#!/usr/bin/env python3
"""A lossy LCM relay between two udpm buses, for reliability tests: forwards chosen channels in
each direction, dropping and swapping messages with seeded probabilities, like a congested UDP
network would.

    lcm_relay.py --a URL_A --b URL_B --a-to-b 'MFOT_SCENE,MFOT_MODEL_.*,MFOT_FRAME_DONE' \
        --b-to-a MFOT_ESTIMATE,MFOT_HEARTBEAT,MFOT_STATUS --drop MFOT_SCENE=0.1 --swap 0.05 --seed 7

A channel name is an LCM channel regex (MFOT_MODEL_.* takes every worker's model channel); --drop and
the counts name it as given. Each one draws from its own generator, seeded from --seed and that name,
so the n-th message of a channel meets the same fate in every run. A swapped message is held back and sent right after the next message on its channel (or after
--hold-s when none comes), so receivers see the two out of order. Prints "ready" once both
buses are open; on SIGTERM or SIGINT prints per-channel counts as one JSON line and exits 0.
"""

from __future__ import annotations

import argparse
import json
import random
import select
import signal
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "scripts"))
import mfot_lcm  # noqa: E402


def probability(text: str) -> tuple[str, float]:
    channel, _, value = text.partition("=")
    try:
        p = float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}': expected CHANNEL=PROBABILITY") from None
    if not channel or not 0.0 <= p <= 1.0:
        raise argparse.ArgumentTypeError(f"'{text}': expected CHANNEL=PROBABILITY with a probability in [0, 1]")
    return channel, p


def channels(text: str) -> list[str]:
    names = [c for c in text.split(",") if c]
    if not names:
        raise argparse.ArgumentTypeError("expected a comma-separated list of channels")
    return names


class Direction:
    """Forwards the chosen channels from one bus to the other."""

    def __init__(self, source: mfot_lcm.Lcm, sink: mfot_lcm.Lcm, names: list[str], drop: dict[str, float],
                 swap: float, hold_s: float, seed: int, counts: dict):
        self.sink, self.drop, self.swap, self.hold_s, self.counts = sink, drop, swap, hold_s, counts
        self.rng = {name: random.Random(f"{seed}:{name}") for name in names}
        self.held: dict[str, tuple[float, bytes, str]] = {}  # by channel: since, message, its name
        for name in names:
            counts.setdefault(name, {"forwarded": 0, "dropped": 0, "swapped": 0})
            source.subscribe(name, lambda channel, data, name=name: self.on_message(name, channel, data))

    def on_message(self, name: str, channel: str, data: bytes) -> None:
        count = self.counts[name]
        rng = self.rng[name]
        if rng.random() < self.drop.get(name, 0.0):
            count["dropped"] += 1
            return
        held = self.held.pop(channel, None)
        if held is None and rng.random() < self.swap:
            self.held[channel] = (time.monotonic(), data, name)
            count["swapped"] += 1
            return
        self.sink.publish(channel, data)
        count["forwarded"] += 1
        if held is not None:
            self.sink.publish(channel, held[1])
            count["forwarded"] += 1

    def release_overdue(self, now: float) -> None:
        for channel in [c for c, (since, _, _) in self.held.items() if now - since >= self.hold_s]:
            _, data, name = self.held.pop(channel)
            self.sink.publish(channel, data)
            self.counts[name]["forwarded"] += 1


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--a", required=True, help="udpm URL of bus A")
    ap.add_argument("--b", required=True, help="udpm URL of bus B")
    ap.add_argument("--a-to-b", type=channels, default=[], help="channels forwarded from A to B")
    ap.add_argument("--b-to-a", type=channels, default=[], help="channels forwarded from B to A")
    ap.add_argument("--drop", type=probability, action="append", default=[], help="CHANNEL=P: drop with probability P")
    ap.add_argument("--swap", type=float, default=0.0, help="probability that a message is sent after the next one")
    ap.add_argument("--hold-s", type=float, default=0.3, help="longest a swapped message is held back, seconds")
    ap.add_argument("--seed", type=int, default=1, help="seed of the relay's own random generators")
    args = ap.parse_args()
    if not 0.0 <= args.swap <= 1.0:
        ap.error(f"--swap {args.swap}: must be in [0, 1]")
    if not 0.0 < args.hold_s <= 10.0:
        ap.error(f"--hold-s {args.hold_s}: must be in (0, 10]")
    if set(args.a_to_b) & set(args.b_to_a):
        ap.error("a channel forwarded both ways would loop between the buses")
    if mfot_lcm.parse_url(args.a) == mfot_lcm.parse_url(args.b):
        ap.error("--a and --b are the same bus")

    stopping = False

    def on_signal(_sig, _frame):
        nonlocal stopping
        stopping = True

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    drop = dict(args.drop)
    counts: dict[str, dict[str, int]] = {}
    with mfot_lcm.Lcm(args.a, recv_buffer_bytes=64 << 20) as bus_a, mfot_lcm.Lcm(args.b, recv_buffer_bytes=64 << 20) as bus_b:
        directions = [Direction(bus_a, bus_b, args.a_to_b, drop, args.swap, args.hold_s, args.seed, counts),
                      Direction(bus_b, bus_a, args.b_to_a, drop, args.swap, args.hold_s, args.seed, counts)]
        print("ready", flush=True)
        while not stopping:
            try:
                ready, _, _ = select.select([bus_a, bus_b], [], [], 0.05)
            except InterruptedError:
                continue
            for bus in ready:
                bus.handle(0)
            now = time.monotonic()
            for direction in directions:
                direction.release_overdue(now)
    print(json.dumps(counts, sort_keys=True), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
