#!/usr/bin/env bash
# Runs scripts/long-functions.sh on the source tree as a test (see that script for what it checks).
# Usage: long_functions.sh SOURCE_DIR [BINARY_DIR HAZMAP_CLI] (the rest unused).
set -euo pipefail
exec bash "${1:?usage: long_functions.sh SOURCE_DIR}/scripts/long-functions.sh"
