#!/usr/bin/env bash
# Runs scripts/check-layers.sh on the source tree as a test (see that script for what it checks).
# Usage: check_layers.sh SOURCE_DIR [BINARY_DIR HAZMAP_CLI] (the rest unused).
set -euo pipefail
exec bash "${1:?usage: check_layers.sh SOURCE_DIR}/scripts/check-layers.sh"
