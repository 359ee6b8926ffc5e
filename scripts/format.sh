#!/usr/bin/env bash
# Formats vlt's own C++ with clang-format (.clang-format at the top). generated/ is left alone: it is
# what vlt-gen writes, byte for byte (the test generated_is_up_to_date), and third_party/ keeps its
# own style. Debian: apt-get install clang-format.
set -euo pipefail
cd "$(dirname "$0")/.."
git ls-files '*.cc' '*.h' | grep -v -E '^(generated|third_party)/' | xargs clang-format -i
