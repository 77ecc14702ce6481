# Shared helpers for the scripts (sourced, not run).
say() { printf '\033[1m[mfot]\033[0m %s\n' "$*"; }
die() { printf '\033[31m[mfot] error:\033[0m %s\n' "$*" >&2; exit 1; }
as_root() {
  if [ "$(id -u)" -eq 0 ]; then "$@"; elif command -v sudo >/dev/null; then sudo "$@"; else die "need root for: $*"; fi
}
# LCM over UDP multicast on loopback: a multicast route via lo and 64 MB socket buffers so 1.5 MB
# frames are not dropped (LCM's multicast set-up guide). Idempotent; skipped when unprivileged.
setup_lcm_network() {
  if [ "$(sysctl -n net.core.rmem_max 2>/dev/null || echo 0)" -lt 67108864 ]; then
    as_root sysctl -q -w net.core.rmem_max=67108864 net.core.rmem_default=67108864 \
      || say "warning: could not raise net.core.rmem_max; large frames may be dropped"
  fi
  if ! ip route show table all 2>/dev/null | grep -q "^multicast 224.0.0.0/4 dev lo\|^224.0.0.0/4 dev lo"; then
    as_root ip route add 224.0.0.0/4 dev lo 2>/dev/null || true
  fi
  as_root ip link set lo multicast on 2>/dev/null || true
}
