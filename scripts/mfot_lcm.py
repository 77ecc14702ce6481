"""Minimal LCM for Python clients, standard library only (Debian ships no python3-lcm).

Speaks the LCM 1.3/1.4 UDP multicast protocol ("udpm" provider) and reads/writes LCM event logs,
so Python controllers can talk to the C++ services and read lcm-logger recordings. Message
payloads are encoded/decoded by the classes lcm-gen -p generates (see load_types()).

Wire format (all integers big-endian):
  short message:  uint32 magic 'LC02' | uint32 seqno | channel NUL | payload
  fragment:       uint32 magic 'LC03' | uint32 seqno | uint32 payload size | uint32 payload offset |
                  uint16 fragment number | uint16 fragment count | (fragment 0: channel NUL) | data
  log event:      uint32 sync 0xEDA1DA01 | int64 event number | int64 utime | int32 channel length |
                  int32 data length | channel (no NUL) | data
"""

from __future__ import annotations

import os
import re
import select
import socket
import struct
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO, Callable, Dict, Iterable, Iterator, List, Optional, Tuple
from urllib.parse import parse_qs, urlsplit

DEFAULT_URL = "udpm://239.255.76.67:7667?ttl=0"

MAGIC_SHORT = 0x4C433032  # "LC02"
MAGIC_FRAGMENT = 0x4C433033  # "LC03"
LOG_SYNC = 0xEDA1DA01

_SHORT_HEADER = struct.Struct(">II")
_FRAGMENT_HEADER = struct.Struct(">IIIIHH")
_LOG_HEADER = struct.Struct(">IqqII")

# LCM's own limits: a datagram carries at most 64 KiB; the C library sends short messages up to
# this size and fragments anything larger.
_MAX_DATAGRAM = 65535
_SHORT_MESSAGE_MAX = 65499
_FRAGMENT_DATA_MAX = 65423
# Refuse absurd reassembly sizes from corrupt headers (the C library caps at 256 MB as well).
_MAX_MESSAGE_SIZE = 256 * 1024 * 1024
# Incomplete fragmented messages kept at once, per sender, before the oldest is dropped.
_MAX_PENDING = 16
# Fragmented messages on channels nobody here subscribed to, remembered (oldest forgotten first) so that
# their further fragments are dropped as they come instead of being reassembled.
_MAX_IGNORED = 64


class LcmError(RuntimeError):
    """A malformed URL, log file or socket failure; the message names what and where."""


@dataclass(frozen=True)
class UdpmUrl:
    group: str
    port: int
    ttl: int


def parse_url(url: Optional[str] = None) -> UdpmUrl:
    """Parses udpm://GROUP:PORT?ttl=N; None or "" means $MFOT_LCM_URL (the process group's), else
    $LCM_DEFAULT_URL, else DEFAULT_URL (as the C++ services' lcm_url())."""
    if not url:
        url = os.environ.get("MFOT_LCM_URL") or os.environ.get("LCM_DEFAULT_URL") or DEFAULT_URL
    parts = urlsplit(url)
    if parts.scheme != "udpm":
        raise LcmError(f"LCM URL '{url}': only the udpm provider is supported by mfot_lcm")
    group = parts.hostname or "239.255.76.67"
    try:
        port = parts.port if parts.port is not None else 7667
    except ValueError as e:
        raise LcmError(f"LCM URL '{url}': bad port ({e})") from None
    try:
        packed = socket.inet_aton(group)
    except OSError:
        raise LcmError(f"LCM URL '{url}': '{group}' is not an IPv4 address") from None
    if not 224 <= packed[0] <= 239:
        raise LcmError(f"LCM URL '{url}': {group} is not a multicast address (224.0.0.0/4)")
    ttl = 0
    for key, values in parse_qs(parts.query, keep_blank_values=True).items():
        if key == "ttl":
            try:
                ttl = int(values[-1])
            except ValueError:
                raise LcmError(f"LCM URL '{url}': ttl must be an integer") from None
            if not 0 <= ttl <= 255:
                raise LcmError(f"LCM URL '{url}': ttl {ttl} is out of range [0, 255]")
        elif key not in ("recv_buf_size",):
            raise LcmError(f"LCM URL '{url}': unknown option '{key}'")
    return UdpmUrl(group, port, ttl)


Handler = Callable[[str, bytes], None]


@dataclass
class _Partial:
    channel: str
    size: int
    data: bytearray
    received: set = field(default_factory=set)
    count: int = 0


class Lcm:
    """One LCM endpoint on a udpm URL: publish(), subscribe() and handle() like lcm.LCM.

    Channels are regular expressions matched against the whole channel name, as in LCM.
    Not thread-safe; call handle() from one thread.
    """

    def __init__(self, url: Optional[str] = None, recv_buffer_bytes: int = 8 * 1024 * 1024):
        self.url = parse_url(url)
        self._subscriptions: List[Tuple[re.Pattern, Handler]] = []
        self._seqno = 0
        self._pending: Dict[Tuple[Tuple[str, int], int], _Partial] = {}
        self._ignored: Dict[Tuple[Tuple[str, int], int], None] = {}  # insertion order: oldest first
        self.malformed = 0  # datagrams that were not valid LCM packets
        group = socket.inet_aton(self.url.group)
        try:
            self._recv = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
            self._recv.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            if hasattr(socket, "SO_REUSEPORT"):
                self._recv.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEPORT, 1)
            self._recv.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, recv_buffer_bytes)
            self._recv.bind(("", self.url.port))
            self._recv.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP,
                                  struct.pack("4s4s", group, socket.inet_aton("0.0.0.0")))
            self._send = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
            self._send.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, self.url.ttl)
            self._send.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_LOOP, 1)
        except OSError as e:
            raise LcmError(f"LCM {self.url.group}:{self.url.port}: socket set-up failed: {e} "
                           "(is there a multicast route? see scripts/lib.sh setup_lcm_network)") from None

    def close(self) -> None:
        self._recv.close()
        self._send.close()

    def __enter__(self) -> "Lcm":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def fileno(self) -> int:
        return self._recv.fileno()

    def subscribe(self, channel_regex: str, handler: Handler) -> None:
        self._subscriptions.append((re.compile(channel_regex), handler))

    def publish(self, channel: str, payload: bytes) -> None:
        name = channel.encode("utf-8") + b"\0"
        seqno = self._seqno
        self._seqno = (self._seqno + 1) & 0xFFFFFFFF
        dest = (self.url.group, self.url.port)
        if _SHORT_HEADER.size + len(name) + len(payload) <= _SHORT_MESSAGE_MAX:
            self._send.sendto(_SHORT_HEADER.pack(MAGIC_SHORT, seqno) + name + payload, dest)
            return
        if len(payload) > _MAX_MESSAGE_SIZE:
            raise LcmError(f"LCM publish on {channel}: {len(payload)} bytes exceeds {_MAX_MESSAGE_SIZE}")
        first = _FRAGMENT_DATA_MAX - len(name)
        count = 1 + (max(0, len(payload) - first) + _FRAGMENT_DATA_MAX - 1) // _FRAGMENT_DATA_MAX
        if count > 0xFFFF:
            raise LcmError(f"LCM publish on {channel}: too many fragments")
        offset = 0
        for number in range(count):
            chunk = first if number == 0 else _FRAGMENT_DATA_MAX
            header = _FRAGMENT_HEADER.pack(MAGIC_FRAGMENT, seqno, len(payload), offset, number, count)
            body = payload[offset:offset + chunk]
            self._send.sendto(header + (name if number == 0 else b"") + body, dest)
            offset += len(body)

    def handle(self, timeout: Optional[float] = None) -> bool:
        """Receives one datagram (waiting up to `timeout` seconds; None waits forever) and
        dispatches the message it completes. Returns False on timeout, True otherwise."""
        if timeout is not None:
            ready, _, _ = select.select([self._recv], [], [], max(0.0, timeout))
            if not ready:
                return False
        packet, sender = self._recv.recvfrom(_MAX_DATAGRAM)
        message = self._accept(packet, sender)
        if message is not None:
            self._dispatch(*message)
        return True

    def handle_until(self, done: Callable[[], bool], timeout: float) -> bool:
        """Handles datagrams until done() is true or `timeout` seconds pass; returns done()."""
        deadline = time.monotonic() + timeout
        while not done():
            left = deadline - time.monotonic()
            if left <= 0:
                break
            self.handle(left)
        return done()

    def _dispatch(self, channel: str, payload: bytes) -> None:
        for pattern, handler in self._subscriptions:
            if pattern.fullmatch(channel):
                handler(channel, payload)

    def _accept(self, packet: bytes, sender: Tuple[str, int]) -> Optional[Tuple[str, bytes]]:
        if len(packet) < _SHORT_HEADER.size:
            self.malformed += 1
            return None
        magic, seqno = _SHORT_HEADER.unpack_from(packet)
        if magic == MAGIC_SHORT:
            end = packet.find(b"\0", _SHORT_HEADER.size)
            if end < 0:
                self.malformed += 1
                return None
            return packet[_SHORT_HEADER.size:end].decode("utf-8", "replace"), packet[end + 1:]
        if magic != MAGIC_FRAGMENT or len(packet) < _FRAGMENT_HEADER.size:
            self.malformed += 1
            return None
        _, _, size, offset, number, count = _FRAGMENT_HEADER.unpack_from(packet)
        data_start = _FRAGMENT_HEADER.size
        key = (sender, seqno)
        if key in self._ignored:
            return None
        partial = self._pending.get(key)
        if number == 0:
            end = packet.find(b"\0", data_start)
            if end < 0:
                self.malformed += 1
                return None
            channel = packet[data_start:end].decode("utf-8", "replace")
            data_start = end + 1
            if not any(pattern.fullmatch(channel) for pattern, _ in self._subscriptions):
                # Nobody here listens on it: not reassembled (a process that follows statuses would
                # otherwise copy every 1.5 MB frame and keep up to _MAX_PENDING of those that lost a
                # fragment).
                self._pending.pop(key, None)
                self._ignored[key] = None
                if len(self._ignored) > _MAX_IGNORED:
                    del self._ignored[next(iter(self._ignored))]
                return None
            if partial is None:
                partial = self._new_partial(key, size, count)
                if partial is None:
                    return None
            partial.channel = channel
        elif partial is None:
            partial = self._new_partial(key, size, count)
            if partial is None:
                return None
        data = packet[data_start:]
        if (partial.size != size or partial.count != count or number >= count
                or offset + len(data) > size):
            self.malformed += 1
            del self._pending[key]
            return None
        if number not in partial.received:
            partial.data[offset:offset + len(data)] = data
            partial.received.add(number)
        if len(partial.received) < count or not partial.channel:
            return None
        del self._pending[key]
        return partial.channel, bytes(partial.data)

    def _new_partial(self, key, size: int, count: int) -> Optional[_Partial]:
        if size > _MAX_MESSAGE_SIZE or count == 0:
            self.malformed += 1
            return None
        # A sender's older incomplete messages are lost once it has moved on far enough.
        same_sender = [k for k in self._pending if k[0] == key[0]]
        if len(same_sender) >= _MAX_PENDING:
            del self._pending[same_sender[0]]
        partial = _Partial(channel="", size=size, data=bytearray(size), count=count)
        self._pending[key] = partial
        return partial


# ---- log files -------------------------------------------------------------------------------


@dataclass(frozen=True)
class LogEvent:
    event_number: int
    utime: int
    channel: str
    data: bytes


def read_log(path: str | os.PathLike, live: bool = False) -> Iterator[LogEvent]:
    """Yields the events of an LCM log file. Every header is checked before its event is read: the
    sync word, a channel length in [1, MAX_LOG_CHANNEL_BYTES], a data length in [0, _MAX_MESSAGE_SIZE],
    both against the bytes left in the file. A file that is empty or does not start with the sync word
    raises LcmError "... not an LCM log"; a corrupt or truncated event raises LcmError naming the file
    and the event's byte offset (LcmLogError, with .offset). With live=True (a log lcm-logger is still
    writing) an empty file or a truncated last event ends the iteration instead."""
    with open(path, "rb") as f:
        yield from _read_events(f, str(path), live)


class LcmLogError(LcmError):
    """A log that is not an LCM log, or an event in it that is truncated or corrupt; offset: its byte."""

    def __init__(self, message: str, offset: int):
        super().__init__(message)
        self.offset = offset


# LCM 1.3's own reader asserts a channel length under 1000 bytes.
MAX_LOG_CHANNEL_BYTES = 999
_LOG_EVENT_HEADER = struct.Struct(">Iqqii")


def _read_events(f: BinaryIO, name: str, live: bool) -> Iterator[LogEvent]:
    size = os.fstat(f.fileno()).st_size
    if size == 0 and not live:
        raise LcmLogError(f"{name} is empty (0 bytes): not an LCM log", 0)
    offset = 0

    def fail(what: str) -> LcmLogError:
        return LcmLogError(f"{name} at byte {offset} of {size}: {what}", offset)

    while True:
        if size - offset < _LOG_EVENT_HEADER.size:
            size = os.fstat(f.fileno()).st_size  # a live log may have grown
        left = size - offset
        if left == 0:
            return
        if left < _LOG_EVENT_HEADER.size:
            if live:
                return
            if offset == 0:
                raise LcmLogError(f"{name}: {left} bytes, too short for an event: not an LCM log", 0)
            raise fail(f"truncated event header: {left} of {_LOG_EVENT_HEADER.size} bytes")
        header = f.read(_LOG_EVENT_HEADER.size)
        if len(header) < _LOG_EVENT_HEADER.size:  # shrank under us
            if live:
                return
            raise fail(f"truncated event header: {len(header)} of {_LOG_EVENT_HEADER.size} bytes")
        sync, number, utime, channel_len, data_len = _LOG_EVENT_HEADER.unpack(header)
        if sync != LOG_SYNC:
            if offset == 0:
                raise LcmLogError(f"{name}: starts with 0x{sync:08x}, not the LCM log sync word 0x{LOG_SYNC:08x}: "
                                  "not an LCM log", 0)
            raise fail(f"bad sync word 0x{sync:08x} (not 0x{LOG_SYNC:08x})")
        if not 1 <= channel_len <= MAX_LOG_CHANNEL_BYTES:
            raise fail(f"event {number}: channel length {channel_len} is out of range [1, {MAX_LOG_CHANNEL_BYTES}]")
        if not 0 <= data_len <= _MAX_MESSAGE_SIZE:
            raise fail(f"event {number}: data length {data_len} is out of range [0, {_MAX_MESSAGE_SIZE}]")
        body = channel_len + data_len
        if body > left - _LOG_EVENT_HEADER.size:
            size = os.fstat(f.fileno()).st_size
            left = size - offset
        if body > left - _LOG_EVENT_HEADER.size:
            if live:
                return
            raise fail(f"event {number} is truncated: it needs {_LOG_EVENT_HEADER.size + body} bytes, "
                       f"the file has {left} left")
        data = f.read(body)
        if len(data) < body:
            if live:
                return
            raise fail(f"event {number} is truncated: the file ends inside it")
        yield LogEvent(number, utime, data[:channel_len].decode("utf-8", "replace"), data[channel_len:])
        offset += _LOG_EVENT_HEADER.size + body


def write_log(path: str | os.PathLike, events: Iterable[Tuple[int, str, bytes]]) -> int:
    """Writes (utime, channel, data) events as an LCM log, numbering them from 0; returns the count."""
    count = 0
    with open(path, "wb") as f:
        for utime, channel, data in events:
            name = channel.encode("utf-8")
            f.write(_LOG_HEADER.pack(LOG_SYNC, count, utime, len(name), len(data)))
            f.write(name)
            f.write(data)
            count += 1
    return count


# ---- generated types -------------------------------------------------------------------------


def default_types_dirs() -> List[Path]:
    repo = Path(__file__).resolve().parent.parent
    return [repo / "build" / "lcmtypes" / "python"]


def percentile(values: Iterable[float], q: float) -> float:
    """The project's one percentile (as common/include/mfot/percentile.hpp): the value at rank
    round(q (n - 1)) of the sorted values, q in [0, 1]; 0.0 for no values."""
    s = sorted(values)
    if not s:
        return 0.0
    return s[int(q * (len(s) - 1) + 0.5)]


def load_types(types_dir: Optional[str] = None):
    """Imports the lcm-gen -p package `mfot` from `types_dir`, $MFOT_LCM_PY_DIR or the default
    build directory, and returns the module."""
    candidates = [Path(types_dir)] if types_dir else []
    if not types_dir and os.environ.get("MFOT_LCM_PY_DIR"):
        candidates.append(Path(os.environ["MFOT_LCM_PY_DIR"]))
    if not candidates:
        candidates = default_types_dirs()
    for directory in candidates:
        if (directory / "mfot" / "__init__.py").is_file():
            if str(directory) not in sys.path:
                sys.path.insert(0, str(directory))
            import mfot  # noqa: PLC0415 - the location is only known at run time

            return mfot
    tried = ", ".join(str(c) for c in candidates)
    raise LcmError(f"generated LCM Python types not found (tried {tried}); build the project "
                   "(target mfot_lcmtypes_gen) and pass --types-dir or set MFOT_LCM_PY_DIR")
