#!/usr/bin/env bash
# Idempotent environment setup: Debian toolchain for the firmware and simboard, then a
# virtual environment with the pinned Python dependencies and porosense installed editable.
# Usage: tools/bootstrap.sh [--no-apt]
set -euo pipefail
top="$(cd "$(dirname "$0")/.." && pwd)"
cd "$top"

# g++ builds the firmware core for the emulator; avrdude uploads through the Uno's bootloader (also in
# tests/firmware/test_bootloader_upload.py); chromium renders the demo's HTML report in its test.
APT_PACKAGES="g++ clang-format gcc-avr avr-libc binutils-avr arduino-core-avr avrdude simavr libsimavr-dev libelf-dev pkg-config chromium"

missing=()
if [ "${1:-}" != "--no-apt" ]; then
  for p in $APT_PACKAGES; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
fi
if [ ${#missing[@]} -gt 0 ]; then
  if [ "$(id -u)" = "0" ]; then
    echo "bootstrap: installing Debian packages: ${missing[*]}"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  else
    echo "bootstrap: missing Debian packages: ${missing[*]}" >&2
    echo "bootstrap: run this once, then retry:" >&2
    echo "    sudo apt-get install -y ${missing[*]}" >&2
    exit 1
  fi
fi

PY="${PYTHON:-python3}"
venv="$top/.venv"
stamp="$venv/.porosense-stamp"
want="$(cat host_sdk/requirements.lock host_sdk/pyproject.toml tools/peers/requirements.txt | sha256sum | cut -c1-16)"
if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ]; then
  exit 0
fi
if [ ! -x "$venv/bin/python" ]; then
  echo "bootstrap: creating $venv"
  "$PY" -m venv "$venv"
fi
# pip on some machines warns about local index folders that do not exist: noise, not news.
quiet_pip() { "$venv/bin/python" -m pip "$@" 2> >(grep -v "is ignored: it is neither a file nor a directory" >&2); }
echo "bootstrap: installing pinned Python dependencies"
quiet_pip install -q --disable-pip-version-check -r host_sdk/requirements.lock
quiet_pip install -q --disable-pip-version-check --no-deps -e host_sdk
# The benchmark peer (SIPPY) is optional: benchmarks report it as absent when it cannot install.
quiet_pip install -q --disable-pip-version-check "sippy-unipi==1.0.1" \
  || echo "bootstrap: sippy-unipi not installed; the identification benchmark will skip its peer"
# SysIdentPy (the NARX peer) pins an older numpy: its own environment, optional as well.
peers="$top/.venv-peers"
if [ ! -x "$peers/bin/python" ]; then
  "$PY" -m venv "$peers" || true
fi
"$peers/bin/python" -m pip install -q --disable-pip-version-check -r tools/peers/requirements.txt \
    2> >(grep -v "is ignored: it is neither a file nor a directory" >&2) \
  || echo "bootstrap: SysIdentPy not installed in $peers; the identification benchmark will skip its NARX peer"
# The emulator runs the firmware core as a host library: build it now (cached by a digest of
# the core's sources; rebuilt on first use after a change), so that a missing C++ compiler
# shows here, in one line.
"$venv/bin/python" - <<'PY'
from porosense.errors import PorosenseError
from porosense.firmware.hostlib import library_path
try:
    library_path()
except PorosenseError as exc:
    raise SystemExit(f"bootstrap: {exc}")
PY
echo "$want" > "$stamp"
