#!/usr/bin/env bash
# Installs what ftpd3d needs on Debian/Ubuntu and is missing: Embree (3.13 on Debian 12, 4.3 on
# Debian 13 / Ubuntu 24.04), libclang for bindgen, pkg-config, a Rust toolchain (rustup) when
# cargo is absent, and for the Python module's tests python3 with venv and pip, and maturin,
# pytest and numpy (pip). Safe to run again: it installs nothing that is already there.
set -euo pipefail
need=()
for pkg in libembree-dev libclang-dev pkg-config python3-venv python3-pip; do
  dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || need+=("$pkg")
done
if [ ${#need[@]} -gt 0 ]; then
  sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  echo "setup: installing ${need[*]}" >&2
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${need[@]}" >/dev/null
fi
if ! command -v cargo >/dev/null 2>&1; then
  echo "setup: no cargo found; installing the Rust toolchain with rustup" >&2
  curl --proto '=https' --tlsv1.2 -sSf https://sh.rustup.rs | sh -s -- -y --profile minimal
  # shellcheck disable=SC1091
  . "$HOME/.cargo/env"
fi
# The Python module's tests (tests/python.rs) build the package with maturin in a venv that sees
# these packages.
if ! python3 -c "import maturin, pytest, numpy" >/dev/null 2>&1; then
  echo "setup: installing maturin, pytest and numpy (pip)" >&2
  python3 -m pip install --quiet maturin pytest numpy 2>/dev/null \
    || python3 -m pip install --quiet --break-system-packages maturin pytest numpy
fi
