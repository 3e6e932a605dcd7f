#!/usr/bin/env bash
# Run a command in the project's environment (underlay, venv, workspace overlay, loopback-only DDS).
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/env.sh"
exec "$@"
