#!/usr/bin/env bash
# Run by CTest (tests/house.cmake `setup_fedora_names`): scripts/lib.sh knows a Fedora name for every
# Debian package it installs, and on a system with dnf and without apt-get vlt_install_packages asks
# dnf for exactly the missing ones by those names (dnf and rpm are stubs here; nothing is installed).
set -euo pipefail
root=$1
stub=$(mktemp -d)
trap 'rm -rf "$stub"' EXIT
source "$root/scripts/lib.sh"
all=("${VLT_BUILD_PACKAGES[@]}" nodejs npm "${VLT_TEST_PACKAGES[@]}" "${VLT_MPI_PACKAGES[@]}" "${VLT_FUZZ_PACKAGES[@]}")
for p in "${all[@]}"; do
  vlt_fedora_name "$p" >/dev/null || { echo "no Fedora name for $p"; exit 1; }
done
# A Fedora-like PATH: dnf records its arguments, rpm says only gcc-c++ is installed, no apt-get.
printf '#!/bin/sh\necho "$@" > %s/dnf.args\n' "$stub" > "$stub/dnf"
printf '#!/bin/sh\n[ "$1" = "-q" ] && [ "$2" = "gcc-c++" ]\n' > "$stub/rpm"
chmod +x "$stub/dnf" "$stub/rpm"
ln -s "$(command -v id)" "$stub/id"
ln -s "$(command -v sudo || command -v id)" "$stub/sudo"
PATH="$stub" vlt_install_packages g++ libginac-dev librandom123-dev libfuzzer-14-dev 2>/dev/null
got=$(cat "$stub/dnf.args")
want="install -y -q ginac-devel Random123-devel compiler-rt"
[ "$got" = "$want" ] || { echo "dnf was asked for '$got', expected '$want'"; exit 1; }
echo "ok: ${#all[@]} Debian packages have Fedora names; dnf is asked for the missing ones: $want"
