"""scripts/mfot_lcm.py and scripts/mfot-pose-client against the real LCM (C library tools
lcm-logger / lcm-logplayer and the C++ example client), over udpm on a random port."""

import math
import os
import random
import shutil
import struct
import subprocess
import sys
import tempfile
import time
import unittest
from pathlib import Path

SOURCE_DIR = Path(os.environ.get("MFOT_SOURCE_DIR", Path(__file__).resolve().parents[2]))
SCRIPTS = SOURCE_DIR / "scripts"
sys.path.insert(0, str(SCRIPTS))
import mfot_lcm  # noqa: E402

TIMEOUT_S = 10.0


def random_url():
    return f"udpm://239.255.76.67:{random.randint(20000, 60000)}?ttl=0"


def load_types_or_skip(test):
    try:
        return mfot_lcm.load_types()
    except mfot_lcm.LcmError as e:
        test.skipTest(str(e))


def sample_poses(mfot, frame_seq=42):
    msg = mfot.poses_t()
    msg.utime = 1_700_000_000_000_000
    msg.frame_seq = frame_seq
    msg.capture_utime = msg.utime - 5000
    for k, (position, yaw_deg) in enumerate((((0.1, -0.025, 0.75), 90.0), ((-0.2, 0.05, 1.2), -30.0))):
        obj = mfot.object_pose_t()
        obj.id = k + 1
        obj.position = list(position)
        half = math.radians(yaw_deg) / 2.0
        obj.orientation = [math.cos(half), 0.0, 0.0, math.sin(half)]  # about z: yaw only
        obj.world_position = [position[0], position[1], position[2] + 1.0]
        obj.world_orientation = [1.0, 0.0, 0.0, 0.0]
        obj.linear_velocity = [0.0, 0.0, 0.0]
        obj.angular_velocity = [0.0, 0.0, 0.0]
        obj.confidence = 0.75
        obj.stale = k == 1
        msg.objects.append(obj)
    msg.num_objects = len(msg.objects)
    return msg


class UrlTest(unittest.TestCase):
    def test_defaults_and_environment(self):
        saved = {k: os.environ.pop(k, None) for k in ("LCM_DEFAULT_URL", "MFOT_LCM_URL")}
        try:
            self.assertEqual(mfot_lcm.parse_url(None), mfot_lcm.UdpmUrl("239.255.76.67", 7667, 0))
            os.environ["LCM_DEFAULT_URL"] = "udpm://239.1.2.3:9000?ttl=1"
            self.assertEqual(mfot_lcm.parse_url(""), mfot_lcm.UdpmUrl("239.1.2.3", 9000, 1))
            os.environ["MFOT_LCM_URL"] = "udpm://239.4.5.6:9001?ttl=1"  # the group's URL comes first
            self.assertEqual(mfot_lcm.parse_url(""), mfot_lcm.UdpmUrl("239.4.5.6", 9001, 1))
            self.assertEqual(mfot_lcm.parse_url("udpm://239.9.9.9:1234"), mfot_lcm.UdpmUrl("239.9.9.9", 1234, 0))
        finally:
            for key, value in saved.items():
                os.environ.pop(key, None)
                if value is not None:
                    os.environ[key] = value

    def test_bad_urls_are_refused(self):
        for url in ("memq://", "udpm://10.0.0.1:7667", "udpm://239.1.1.1:7667?ttl=300",
                    "udpm://239.1.1.1:7667?ttl=x", "udpm://239.1.1.1:7667?mtu=5", "udpm://239.1.1.1:99999"):
            with self.assertRaises(mfot_lcm.LcmError, msg=url):
                mfot_lcm.parse_url(url)


class LoopbackTest(unittest.TestCase):
    def test_short_and_fragmented_messages_arrive_whole(self):
        url = random_url()
        received = []
        big = bytes(random.getrandbits(8) for _ in range(300_000))
        with mfot_lcm.Lcm(url) as lcm:
            lcm.subscribe("MFOT_.*", lambda channel, data: received.append((channel, data)))
            lcm.publish("MFOT_SMALL", b"small")
            lcm.publish("OTHER", b"not subscribed")
            lcm.publish("MFOT_BIG", big)
            self.assertTrue(lcm.handle_until(lambda: len(received) >= 2, TIMEOUT_S))
        self.assertEqual(received, [("MFOT_SMALL", b"small"), ("MFOT_BIG", big)])

    def test_fragments_of_channels_nobody_subscribed_to_are_not_kept(self):
        # A status follower hears every frame's fragments: an unsubscribed channel's message must not be
        # reassembled, nor kept when a fragment of it is lost (up to _MAX_PENDING frames per sender).
        url = random_url()
        received = []
        with mfot_lcm.Lcm(url) as lcm:
            lcm.subscribe("MFOT_STATUS", lambda channel, data: received.append((channel, data)))
            packets = []

            class Capture:  # the datagrams publish() would send
                def sendto(self, packet, _dest):
                    packets.append(packet)

                def close(self):
                    pass

            real_send, lcm._send = lcm._send, Capture()
            self.addCleanup(real_send.close)
            big = bytes(200_000)
            sender = ("127.0.0.1", 7667)
            for _ in range(40):
                packets.clear()
                lcm.publish("MFOT_FRAME", big)
                self.assertGreater(len(packets), 2)
                for packet in packets[:-1]:  # the last fragment lost
                    self.assertIsNone(lcm._accept(packet, sender))
                self.assertEqual(len(lcm._pending), 0)
                self.assertLessEqual(len(lcm._ignored), mfot_lcm._MAX_IGNORED)
            # A subscribed channel is reassembled as before, its fragments in any order.
            packets.clear()
            lcm.publish("MFOT_STATUS", big)
            whole = [lcm._accept(packet, sender) for packet in reversed(packets)]
            self.assertEqual(whole[-1], ("MFOT_STATUS", big))
            self.assertEqual(len(lcm._pending), 0)
            lcm._send = real_send

    def test_garbage_datagrams_are_counted_not_delivered(self):
        url = random_url()
        received = []
        with mfot_lcm.Lcm(url) as lcm:
            lcm.subscribe(".*", lambda channel, data: received.append(channel))
            parsed = mfot_lcm.parse_url(url)
            lcm._send.sendto(b"\x00\x01", (parsed.group, parsed.port))
            lcm._send.sendto(struct.pack(">II", 0x12345678, 0) + b"X\0data", (parsed.group, parsed.port))
            lcm.publish("AFTER", b"ok")
            self.assertTrue(lcm.handle_until(lambda: received, TIMEOUT_S))
        self.assertEqual(received, ["AFTER"])
        self.assertEqual(lcm.malformed, 2)


@unittest.skipUnless(shutil.which("lcm-logger") and shutil.which("lcm-logplayer"), "liblcm-bin not installed")
class CInteropTest(unittest.TestCase):
    def setUp(self):
        self.mfot = load_types_or_skip(self)
        self.tmp = tempfile.TemporaryDirectory()
        self.addCleanup(self.tmp.cleanup)

    def test_lcm_logger_records_what_python_publishes(self):
        url = random_url()
        log = Path(self.tmp.name) / "python.lcmlog"
        poses = sample_poses(self.mfot).encode()
        big = bytes(range(256)) * 800  # fragmented
        logger = subprocess.Popen(["lcm-logger", "-q", "-f", "--flush-interval=10", f"--lcm-url={url}", str(log)],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        self.addCleanup(logger.wait)
        self.addCleanup(logger.terminate)
        events = []
        with mfot_lcm.Lcm(url) as lcm:
            deadline = time.monotonic() + TIMEOUT_S
            # lcm-logger joins the group at some point after start: publish until it has both.
            while time.monotonic() < deadline:
                lcm.publish("MFOT_POSES", poses)
                lcm.publish("BIG", big)
                lcm.handle(0.05)
                events = list(mfot_lcm.read_log(log, live=True)) if log.exists() else []
                if {"MFOT_POSES", "BIG"} <= {e.channel for e in events}:
                    break
        by_channel = {e.channel: e for e in events}
        self.assertIn("MFOT_POSES", by_channel)
        self.assertIn("BIG", by_channel)
        self.assertEqual(by_channel["BIG"].data, big)
        decoded = self.mfot.poses_t.decode(by_channel["MFOT_POSES"].data)
        self.assertEqual(decoded.frame_seq, 42)
        self.assertEqual([o.id for o in decoded.objects], [1, 2])
        self.assertEqual([e.event_number for e in events], list(range(len(events))))

    def test_python_receives_what_lcm_logplayer_publishes(self):
        url = random_url()
        log = Path(self.tmp.name) / "play.lcmlog"
        poses = sample_poses(self.mfot, frame_seq=7).encode()
        big = bytes(random.getrandbits(8) for _ in range(200_000))
        now = int(time.time() * 1e6)
        mfot_lcm.write_log(log, [(now, "MFOT_POSES", poses), (now + 1000, "BIG", big)])
        received = {}
        with mfot_lcm.Lcm(url) as lcm:
            lcm.subscribe(".*", lambda channel, data: received.setdefault(channel, data))
            player = subprocess.run(["lcm-logplayer", f"--lcm-url={url}", str(log)], capture_output=True,
                                    timeout=TIMEOUT_S)
            self.assertEqual(player.returncode, 0, player.stderr)
            lcm.handle_until(lambda: len(received) >= 2, TIMEOUT_S)
        self.assertEqual(received.get("BIG"), big)
        self.assertEqual(self.mfot.poses_t.decode(received["MFOT_POSES"]).frame_seq, 7)

class LogReaderTest(unittest.TestCase):
    """read_log: every broken log is reported with its byte offset, a foreign file as not an LCM log,
    and no header value is trusted before it is checked against the file."""

    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.addCleanup(self.tmp.cleanup)
        self.log = Path(self.tmp.name) / "test.lcmlog"
        mfot_lcm.write_log(self.log, [(1, "A", b"12345"), (2, "B", b"678")])  # events at bytes 0 and 34
        self.good = self.log.read_bytes()

    def error(self, data: bytes, live: bool = False) -> mfot_lcm.LcmLogError:
        self.log.write_bytes(data)
        with self.assertRaises(mfot_lcm.LcmLogError) as caught:
            list(mfot_lcm.read_log(self.log, live=live))
        return caught.exception

    @staticmethod
    def header(number=1, channel_len=1, data_len=3, sync=mfot_lcm.LOG_SYNC):
        return struct.pack(">Iqqii", sync, number, 2, channel_len, data_len)

    def test_a_good_log_reads_back(self):
        events = list(mfot_lcm.read_log(self.log))
        self.assertEqual([(e.event_number, e.utime, e.channel, e.data) for e in events],
                         [(0, 1, "A", b"12345"), (1, 2, "B", b"678")])

    def test_truncated_mid_header(self):
        e = self.error(self.good[:34 + 10])
        self.assertEqual(e.offset, 34)
        self.assertRegex(str(e), r"test.lcmlog at byte 34 of 44: truncated event header: 10 of 28 bytes")
        self.assertEqual([ev.channel for ev in mfot_lcm.read_log(self.log, live=True)], ["A"])

    def test_truncated_mid_payload(self):
        e = self.error(self.good[:-2])
        self.assertEqual(e.offset, 34)
        self.assertRegex(str(e), r"at byte 34 of 64: event 1 is truncated: it needs 32 bytes, the file has 30 left")
        self.assertEqual([ev.channel for ev in mfot_lcm.read_log(self.log, live=True)], ["A"])

    def test_bad_sync_word(self):
        e = self.error(self.good[:34] + b"\x00" + self.good[35:])
        self.assertEqual(e.offset, 34)
        self.assertRegex(str(e), r"at byte 34 of 66: bad sync word 0x00a1da01")
        # Also while live: a corrupt event is not the end of a log being written.
        self.assertEqual(self.error(self.good[:34] + b"\x00" + self.good[35:], live=True).offset, 34)

    def test_huge_data_length(self):
        e = self.error(self.good[:34] + self.header(data_len=0x7FFFFFFF) + b"B678")
        self.assertEqual(e.offset, 34)
        self.assertRegex(str(e), r"event 1: data length 2147483647 is out of range \[0, 268435456\]")
        self.assertRegex(str(self.error(self.good[:34] + self.header(data_len=-5) + b"B678")),
                         r"data length -5 is out of range")
        # Plausible, but more than the file holds: truncated, read without allocating it.
        self.assertRegex(str(self.error(self.good[:34] + self.header(data_len=100_000_000) + b"B678")),
                         r"event 1 is truncated: it needs 100000029 bytes, the file has 32 left")

    def test_huge_channel_length(self):
        e = self.error(self.good[:34] + self.header(channel_len=0x7FFFFFFF) + b"B678")
        self.assertEqual(e.offset, 34)
        self.assertRegex(str(e), r"event 1: channel length 2147483647 is out of range \[1, 999\]")
        self.assertRegex(str(self.error(self.good[:34] + self.header(channel_len=0) + b"678")),
                         r"channel length 0 is out of range")

    def test_empty_file(self):
        e = self.error(b"")
        self.assertEqual(e.offset, 0)
        self.assertRegex(str(e), r"test.lcmlog is empty \(0 bytes\): not an LCM log")
        self.assertEqual(list(mfot_lcm.read_log(self.log, live=True)), [])  # lcm-logger has not written yet

    def test_foreign_file(self):
        self.assertRegex(str(self.error(Path(sys.executable).read_bytes()[:4096])),
                         r"starts with 0x7f454c46, not the LCM log sync word 0xeda1da01: not an LCM log")
        self.assertRegex(str(self.error(b"\xed\xa1")), r"2 bytes, too short for an event: not an LCM log")


class PoseClientTest(unittest.TestCase):
    """Both example clients print the same lines for the same message."""

    def setUp(self):
        self.mfot = load_types_or_skip(self)

    def run_clients(self, commands, url, message, garbage=None):
        clients = [subprocess.Popen(c, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for c in commands]
        for c in clients:
            self.addCleanup(c.kill)
        with mfot_lcm.Lcm(url) as lcm:
            deadline = time.monotonic() + TIMEOUT_S
            # The clients join at some point after start: publish until every one has exited.
            while time.monotonic() < deadline and any(c.poll() is None for c in clients):
                if garbage is not None:
                    lcm.publish("MFOT_POSES", garbage)
                lcm.publish("MFOT_POSES", message)
                lcm.handle(0.05)
        outputs = []
        self.errors = []
        for c in clients:
            out, err = c.communicate(timeout=TIMEOUT_S)
            self.assertEqual(c.returncode, 0, err)
            outputs.append(out.splitlines())
            self.errors.append(err)
        return outputs

    def test_python_client_prints_poses(self):
        url = random_url()
        command = [sys.executable, str(SCRIPTS / "mfot-pose-client"), "--lcm-url", url, "--count", "1"]
        [lines] = self.run_clients([command], url, sample_poses(self.mfot).encode())
        self.assertEqual(lines, [
            "frame=42 id=1 x_mm=100.0 y_mm=-25.0 z_mm=750.0 roll_deg=0.00 pitch_deg=0.00 yaw_deg=90.00 "
            "confidence=0.750 stale=0",
            "frame=42 id=2 x_mm=-200.0 y_mm=50.0 z_mm=1200.0 roll_deg=0.00 pitch_deg=0.00 yaw_deg=-30.00 "
            "confidence=0.750 stale=1",
        ])

    @unittest.skipUnless(os.environ.get("MFOT_POSE_CLIENT"), "MFOT_POSE_CLIENT (C++ client) not given")
    def test_cpp_and_python_clients_agree(self):
        url = random_url()
        msg = sample_poses(self.mfot)
        obj = msg.objects[0]
        # A general rotation: roll 10, pitch -20, yaw 35 degrees (Z-Y-X).
        r, p, y = (math.radians(a) / 2.0 for a in (10.0, -20.0, 35.0))
        obj.orientation = [
            math.cos(r) * math.cos(p) * math.cos(y) + math.sin(r) * math.sin(p) * math.sin(y),
            math.sin(r) * math.cos(p) * math.cos(y) - math.cos(r) * math.sin(p) * math.sin(y),
            math.cos(r) * math.sin(p) * math.cos(y) + math.sin(r) * math.cos(p) * math.sin(y),
            math.cos(r) * math.cos(p) * math.sin(y) - math.sin(r) * math.sin(p) * math.cos(y),
        ]
        for world in (False, True):
            flags = ["--lcm-url", url, "--count", "1"] + (["--world"] if world else [])
            cpp, python = self.run_clients(
                [[os.environ["MFOT_POSE_CLIENT"]] + flags,
                 [sys.executable, str(SCRIPTS / "mfot-pose-client")] + flags], url, msg.encode())
            self.assertEqual(cpp, python)
            self.assertEqual(len(cpp), 2)
            if not world:
                self.assertIn("roll_deg=10.00 pitch_deg=-20.00 yaw_deg=35.00", cpp[0])
            else:
                self.assertIn("z_mm=1750.0 roll_deg=0.00 pitch_deg=0.00 yaw_deg=0.00", cpp[0])

    def test_undecodable_messages_are_reported_and_skipped(self):
        url = random_url()
        # Two good messages: the garbage published between them reaches every client.
        commands = [[sys.executable, str(SCRIPTS / "mfot-pose-client"), "--lcm-url", url, "--count", "2"]]
        if os.environ.get("MFOT_POSE_CLIENT"):
            commands.append([os.environ["MFOT_POSE_CLIENT"], "--lcm-url", url, "--count", "2"])
        encoded = sample_poses(self.mfot).encode()
        outputs = self.run_clients(commands, url, encoded, garbage=encoded[:20])
        for lines, err in zip(outputs, self.errors):
            self.assertEqual(len(lines), 4)
            self.assertIn("undecodable", err)



class PercentileTest(unittest.TestCase):
    def test_rank_of_the_cxx_percentile(self):
        # common/include/mfot/percentile.hpp: rank round(q (n - 1)) of the sorted values.
        self.assertEqual(mfot_lcm.percentile([5, 1, 3, 2, 4], 0.5), 3)
        self.assertEqual(mfot_lcm.percentile(range(101), 0.99), 99)
        self.assertEqual(mfot_lcm.percentile([2.0, 1.0], 0.0), 1.0)
        self.assertEqual(mfot_lcm.percentile([2.0, 1.0], 1.0), 2.0)
        self.assertEqual(mfot_lcm.percentile([], 0.9), 0.0)


if __name__ == "__main__":
    unittest.main()
