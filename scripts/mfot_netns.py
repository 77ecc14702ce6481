"""Simulated hosts on one machine, for tests and benchmarks of a group spread over several hosts.

Each host is a network namespace of its own (with its own host name, through a UTS namespace per
process) joined to the others by a veth link to a bridge in a "switch" namespace, as machines on
one LAN switch are. Only addresses inside these namespaces are used (10.213.0.0/24); everything is
torn down on exit, also after a failure. Needs root (CI runs as root) and iproute2.

    with SimulatedHosts(["host-a", "host-b"]) as hosts:
        proc = hosts.start("host-a", ["scripts/mfot-run", ...], log_path)
        ...
        hosts.kill("host-b")           # every process of that host, as a pulled cable would
        hosts.tx_bytes("host-a")      # bytes host-a sent on its link
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
from pathlib import Path

SUBNET = "10.213.0"


def available() -> tuple[bool, str]:
    """Whether simulated hosts can be made here (a namespace, a bridge, a veth link, a UTS namespace),
    and why not."""
    if os.geteuid() != 0:
        return False, "network namespaces need root"
    for tool in ("ip", "unshare"):
        if shutil.which(tool) is None:
            return False, f"{tool} is not installed (iproute2 / util-linux)"
    probe = f"mfot-probe-{os.getpid()}"
    steps = [["ip", "netns", "add", probe],
             ["ip", "-n", probe, "link", "add", "br0", "type", "bridge", "mcast_snooping", "0"],
             ["ip", "-n", probe, "link", "add", "a0", "type", "veth", "peer", "name", "b0"],
             ["ip", "-n", probe, "link", "set", "a0", "master", "br0"],
             ["ip", "netns", "exec", probe, "unshare", "--uts", "true"]]
    try:
        for step in steps:
            res = subprocess.run(step, capture_output=True, text=True)
            if res.returncode != 0:
                return False, f"cannot simulate hosts here: {' '.join(step)}: {res.stderr.strip()}"
        return True, ""
    finally:
        subprocess.run(["ip", "netns", "del", probe], capture_output=True)


class SimulatedHosts:
    def __init__(self, names: list[str]):
        tag = f"{os.getpid() % 100000}"
        self.names = names
        self.ns = {name: f"mfot-{i}-{tag}" for i, name in enumerate(names)}
        self.switch = f"mfot-sw-{tag}"
        self.procs: dict[str, list[subprocess.Popen]] = {name: [] for name in names}

    def __enter__(self) -> "SimulatedHosts":
        try:
            self._ip("netns", "add", self.switch)
            self._ip("-n", self.switch, "link", "add", "br0", "type", "bridge", "mcast_snooping", "0")
            self._ip("-n", self.switch, "link", "set", "br0", "up")
            for i, name in enumerate(self.names):
                ns = self.ns[name]
                self._ip("netns", "add", ns)
                self._ip("-n", ns, "link", "set", "lo", "up")
                # The host's end is "eth0" in its namespace; the switch's end joins the bridge.
                self._ip("link", "add", "eth0", "netns", ns, "type", "veth", "peer", "name", f"port{i}",
                         "netns", self.switch)
                self._ip("-n", self.switch, "link", "set", f"port{i}", "master", "br0", "up")
                self._ip("-n", ns, "addr", "add", f"{SUBNET}.{i + 1}/24", "dev", "eth0")
                self._ip("-n", ns, "link", "set", "eth0", "up", "multicast", "on")
                self._ip("-n", ns, "route", "add", "224.0.0.0/4", "dev", "eth0")
                # LCM's large frames need large socket buffers (as scripts/lib.sh sets for one host).
                subprocess.run(["ip", "netns", "exec", ns, "sysctl", "-q", "-w", "net.core.rmem_max=67108864",
                                "net.core.rmem_default=67108864"], capture_output=True)
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self

    def start(self, host: str, argv: list[str], log_path: Path, env: dict | None = None,
              cwd: Path | None = None) -> subprocess.Popen:
        """Starts argv on `host` (its namespace, its host name) in a session of its own."""
        wrapped = ["ip", "netns", "exec", self.ns[host], "unshare", "--uts", "sh", "-c",
                   f'hostname {host} && exec "$@"', "sh", *argv]
        log = open(log_path, "ab")
        proc = subprocess.Popen(wrapped, stdout=log, stderr=subprocess.STDOUT, env=env, cwd=cwd, start_new_session=True)
        log.close()
        self.procs[host].append(proc)
        return proc

    def kill(self, host: str) -> None:
        """Every process in `host`'s namespace at once (SIGKILL), as a pulled cable or power would."""
        self._kill_namespace(self.ns[host])
        for proc in self.procs[host]:
            proc.wait()

    def _kill_namespace(self, ns: str) -> None:
        res = subprocess.run(["ip", "netns", "pids", ns], capture_output=True, text=True)
        for pid in res.stdout.split():
            try:
                os.kill(int(pid), signal.SIGKILL)
            except ProcessLookupError:
                pass

    def tx_bytes(self, host: str) -> int:
        """Bytes `host` has sent on its link."""
        res = subprocess.run(["ip", "netns", "exec", self.ns[host], "cat", "/sys/class/net/eth0/statistics/tx_bytes"],
                             capture_output=True, text=True, check=True)
        return int(res.stdout.strip())

    def __exit__(self, *_exc) -> None:
        # A clean stop first (mfot-run stops its services on SIGTERM), then whatever is left.
        for procs in self.procs.values():
            for proc in procs:
                if proc.poll() is None:
                    proc.send_signal(signal.SIGTERM)
        for procs in self.procs.values():
            for proc in procs:
                try:
                    proc.wait(15)
                except subprocess.TimeoutExpired:
                    pass
        for ns in self.ns.values():
            self._kill_namespace(ns)
        for procs in self.procs.values():
            for proc in procs:
                if proc.poll() is None:
                    proc.kill()
                    proc.wait()
        for ns in list(self.ns.values()) + [self.switch]:
            subprocess.run(["ip", "netns", "del", ns], capture_output=True)

    @staticmethod
    def _ip(*args: str) -> None:
        res = subprocess.run(["ip", *args], capture_output=True, text=True)
        if res.returncode != 0:
            raise RuntimeError(f"ip {' '.join(args)}: {res.stderr.strip()}")
