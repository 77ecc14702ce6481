"""scripts/mfot_auth.py, the Python twin of MessageAuthenticator (issue 55): stamping, the group check,
HMAC-SHA256, replay, the key file's mode and length; and that its MAC is the C++ one (the same test
vector as tests/services/test_message_authenticator.cpp)."""

from __future__ import annotations

import os
import sys
import tempfile
import unittest
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "scripts"))
import mfot_auth  # noqa: E402
import mfot_lcm  # noqa: E402

TYPES = mfot_lcm.load_types(os.environ.get("MFOT_LCM_PY_DIR"))
NOW = 1_700_000_000_000_000
KEY = b"k" * 32
# HMAC-SHA256 of heartbeat() stamped by group 5, sender 1001, sequence 1 with KEY (as in the C++ test).
CPP_MAC_HEX = "eb9899a4c3f005d2800b19818742eb5bc11cf56265c7c3c80c3ccba57ecc8c04"


def heartbeat() -> bytes:
    hb = TYPES.heartbeat_t()
    hb.utime = NOW
    hb.worker_id, hb.instance, hb.host, hb.object_id, hb.last_frame_seq = 3, 42, "host", 7, 11
    return hb.encode()


class AuthenticatorTest(unittest.TestCase):
    def test_stamped_message_is_accepted_and_decodes(self):
        sender = mfot_auth.Authenticator(5, KEY, sender=1001)
        receiver = mfot_auth.Authenticator(5, KEY, sender=2002)
        message = sender.stamp(heartbeat())
        self.assertEqual(receiver.verify("MFOT_HEARTBEAT", message, NOW), "accepted")
        decoded = TYPES.heartbeat_t.decode(message)
        self.assertEqual((decoded.envelope.group_id, decoded.envelope.sender, decoded.envelope.sequence), (5, 1001, 1))
        self.assertEqual(decoded.object_id, 7)

    def test_mac_is_the_cpp_one(self):
        # The C++ test stamps the same heartbeat with the same key, group and sender and expects this MAC.
        message = mfot_auth.Authenticator(5, KEY, sender=1001).stamp(heartbeat())
        self.assertEqual(message[mfot_auth.MAC_OFFSET:mfot_auth.ENVELOPE_END].hex(), CPP_MAC_HEX)

    def test_altered_byte_or_wrong_key_is_forged(self):
        message = mfot_auth.Authenticator(5, KEY, sender=1001).stamp(heartbeat())
        for i in list(range(0, 16)) + list(range(24, len(message))):
            altered = bytearray(message)
            altered[i] ^= 1
            receiver = mfot_auth.Authenticator(5, KEY)
            self.assertEqual(receiver.verify("MFOT_HEARTBEAT", bytes(altered), NOW), "forged", f"byte {i}")
        self.assertEqual(mfot_auth.Authenticator(5, b"x" * 32).verify("MFOT_HEARTBEAT", message, NOW), "forged")

    def test_other_group_is_foreign_and_replay_is_replayed(self):
        receiver = mfot_auth.Authenticator(5, KEY)
        other = mfot_auth.Authenticator(6, KEY).stamp(heartbeat())
        self.assertEqual(receiver.verify("MFOT_HEARTBEAT", other, NOW), "foreign")
        sender = mfot_auth.Authenticator(5, KEY)
        first, second = sender.stamp(heartbeat()), sender.stamp(heartbeat())
        self.assertEqual(receiver.verify("MFOT_HEARTBEAT", second, NOW), "accepted")
        self.assertEqual(receiver.verify("MFOT_HEARTBEAT", first, NOW), "replayed")
        self.assertEqual(receiver.verify("MFOT_HEARTBEAT", second, NOW), "replayed")
        self.assertEqual(receiver.counts, {"foreign": 1, "forged": 0, "replayed": 2})

    def test_without_key_only_the_group_is_checked(self):
        receiver = mfot_auth.Authenticator(5)
        message = mfot_auth.Authenticator(5).stamp(heartbeat())
        self.assertEqual(message[mfot_auth.MAC_OFFSET:mfot_auth.ENVELOPE_END], bytes(32))
        self.assertEqual(receiver.verify("MFOT_HEARTBEAT", message, NOW), "accepted")
        self.assertEqual(receiver.verify("MFOT_HEARTBEAT", message, NOW), "accepted")
        self.assertEqual(receiver.verify("MFOT_HEARTBEAT", mfot_auth.Authenticator(9).stamp(heartbeat()), NOW),
                         "foreign")

    def test_key_file_mode_and_length(self):
        with tempfile.TemporaryDirectory() as d:
            path = Path(d) / "key"
            path.write_bytes(KEY)
            path.chmod(0o600)
            self.assertEqual(mfot_auth.load_key(str(path)), KEY)
            path.chmod(0o644)
            with self.assertRaisesRegex(mfot_auth.KeyFileError, "mode 0644"):
                mfot_auth.load_key(str(path))
            path.write_bytes(b"short")
            path.chmod(0o600)
            with self.assertRaisesRegex(mfot_auth.KeyFileError, "5 bytes"):
                mfot_auth.load_key(str(path))

    def test_group_id_range(self):
        for bad in (0, -1, (1 << 53) + 1, "1", True):
            with self.assertRaises(ValueError):
                mfot_auth.Authenticator(bad)

if __name__ == "__main__":
    unittest.main()
