"""Group identity and message authentication for Python clients (issue 55), standard library only.

The Python twin of services/common's MessageAuthenticator: every top-level mfot message has
envelope_t (lcmtypes/envelope_t.lcm) as its second field, so in the encoded bytes it sits at a fixed
offset: fingerprint 8 | utime 8 | group_id 8 | sender 8 | sequence 8 | mac 32. stamp() fills it in an
encoded message (from the generated types' encode()); verify() checks a received one:
  group_id not ours -> "foreign"; with a key: HMAC-SHA256 (over the message with mac zeroed) wrong ->
  "forged"; sequence not above the last accepted from that sender on that channel, or utime further than
  max_age_s from now -> "replayed". Messages are still read only through the generated types.
"""

from __future__ import annotations

import hashlib
import hmac
import os
import secrets
import stat
import struct
import threading
import time
from typing import Dict, Optional, Tuple

GROUP_OFFSET = 16
SENDER_OFFSET = 24
SEQUENCE_OFFSET = 32
MAC_OFFSET = 40
MAC_BYTES = 32
ENVELOPE_END = 72
MAX_GROUP_ID = 1 << 53  # group.id's range is [1, 2^53] (configs/default.yaml)
MIN_KEY_BYTES = 32
MAX_KEY_BYTES = 4096
MAX_REMEMBERED_SENDERS = 4096
VERDICTS = ("accepted", "no envelope", "foreign", "forged", "replayed")

_INT64 = struct.Struct(">q")


class KeyFileError(ValueError):
    """A group key file that cannot be used; the message names the path and the problem."""


def load_key(path: str) -> bytes:
    """The whole file: a regular file of 32..4096 bytes that neither group nor others may access."""
    where = f"group.key_file '{path}'"
    try:
        st = os.stat(path)
    except OSError as e:
        raise KeyFileError(f"{where}: cannot stat: {e.strerror}") from None
    if not stat.S_ISREG(st.st_mode):
        raise KeyFileError(f"{where}: not a regular file")
    if st.st_mode & 0o077:
        raise KeyFileError(f"{where}: mode {stat.S_IMODE(st.st_mode):04o} lets the group or others access the key; "
                        "it must be readable by its owner only (chmod 600)")
    if not MIN_KEY_BYTES <= st.st_size <= MAX_KEY_BYTES:
        raise KeyFileError(f"{where}: {st.st_size} bytes; a key has {MIN_KEY_BYTES} to {MAX_KEY_BYTES} "
                        "(e.g. head -c 32 /dev/urandom > key)")
    with open(path, "rb") as f:
        return f.read(MAX_KEY_BYTES + 1)


def group_id_of(payload: bytes) -> Optional[int]:
    """The envelope's group id of an encoded message, None when it is too short to have one."""
    if len(payload) < ENVELOPE_END:
        return None
    return _INT64.unpack_from(payload, GROUP_OFFSET)[0]


def sender_of(payload: bytes) -> Optional[int]:
    if len(payload) < ENVELOPE_END:
        return None
    return _INT64.unpack_from(payload, SENDER_OFFSET)[0]


class Authenticator:
    def __init__(self, group_id: int, key: Optional[bytes] = None, sender: Optional[int] = None,
                 max_age_s: float = 0.0):
        if not isinstance(group_id, int) or isinstance(group_id, bool) or not 1 <= group_id <= MAX_GROUP_ID:
            raise ValueError(f"group.id must be an integer in [1, {MAX_GROUP_ID}], got {group_id!r}")
        if key is not None and len(key) < MIN_KEY_BYTES:
            raise ValueError(f"a group key has at least {MIN_KEY_BYTES} bytes")
        self.group_id = group_id
        self.key = key or None
        self.sender = sender if sender is not None else secrets.randbits(62) + 1
        self.max_age_us = int(round(max_age_s * 1e6))
        self.counts = {"foreign": 0, "forged": 0, "replayed": 0}
        self._next_sequence = 1
        self._last: Dict[Tuple[int, str], Tuple[int, int]] = {}
        self._heard = 0
        self._lock = threading.Lock()

    @classmethod
    def from_config(cls, group: dict) -> "Authenticator":
        """From a config's group section (group.id, group.key_file, group.max_message_age_s)."""
        key_file = group.get("key_file") or ""
        return cls(group.get("id"), load_key(key_file) if key_file else None,
                   max_age_s=float(group.get("max_message_age_s") or 0.0))

    def _mac(self, payload: bytes) -> bytes:
        m = hmac.new(self.key, digestmod=hashlib.sha256)
        m.update(payload[:MAC_OFFSET])
        m.update(bytes(MAC_BYTES))
        m.update(payload[ENVELOPE_END:])
        return m.digest()

    def stamp(self, payload: bytes) -> bytes:
        """The encoded message with this group's envelope: group, sender, next sequence, MAC."""
        if len(payload) < ENVELOPE_END:
            raise ValueError(f"{len(payload)} bytes: too short for a message with an envelope")
        with self._lock:
            sequence = self._next_sequence
            self._next_sequence += 1
        out = bytearray(payload)
        _INT64.pack_into(out, GROUP_OFFSET, self.group_id)
        _INT64.pack_into(out, SENDER_OFFSET, self.sender)
        _INT64.pack_into(out, SEQUENCE_OFFSET, sequence)
        out[MAC_OFFSET:ENVELOPE_END] = self._mac(bytes(out)) if self.key else bytes(MAC_BYTES)
        return bytes(out)

    def authentic(self, payload: bytes) -> bool:
        """Group and MAC only (no sequence): for reading a recorded log of this group."""
        if group_id_of(payload) != self.group_id:
            return False
        return self.key is None or hmac.compare_digest(self._mac(payload), payload[MAC_OFFSET:ENVELOPE_END])

    def verify(self, channel: str, payload: bytes, now_utime: Optional[int] = None) -> str:
        """One of VERDICTS; what is dropped is counted in self.counts."""
        if len(payload) < ENVELOPE_END:
            return "no envelope"
        with self._lock:
            if group_id_of(payload) != self.group_id:
                self.counts["foreign"] += 1
                return "foreign"
            if self.key is None:
                return "accepted"
            if not hmac.compare_digest(self._mac(payload), payload[MAC_OFFSET:ENVELOPE_END]):
                self.counts["forged"] += 1
                return "forged"
            now = int(time.time() * 1e6) if now_utime is None else now_utime
            utime = _INT64.unpack_from(payload, 8)[0]
            sender = _INT64.unpack_from(payload, SENDER_OFFSET)[0]
            sequence = _INT64.unpack_from(payload, SEQUENCE_OFFSET)[0]
            last = self._last.get((sender, channel))
            if (self.max_age_us > 0 and abs(utime - now) > self.max_age_us) or sequence < 1 or \
                    (last is not None and sequence <= last[0]):
                self.counts["replayed"] += 1
                return "replayed"
            self._heard += 1
            if last is None and len(self._last) >= MAX_REMEMBERED_SENDERS:
                del self._last[min(self._last, key=lambda k: self._last[k][1])]
            self._last[(sender, channel)] = (sequence, self._heard)
            return "accepted"
