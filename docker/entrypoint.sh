#!/usr/bin/env bash
# Starts the mfot process group inside the container. LCM uses the host network (--net host);
# MFOT_LCM_URL widens it beyond this host, e.g. udpm://239.255.76.67:7667?ttl=1.
set -euo pipefail
cd /mfot
exec python3 scripts/mfot-run --build-dir build --config configs/default.yaml "$@"
