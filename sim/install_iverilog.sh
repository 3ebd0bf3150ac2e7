#!/usr/bin/env bash
# Install Icarus Verilog (Debian package `iverilog`) when this machine can, so
# that the cocotb suite also runs on it. Never fails: without root, apt or the
# network the suite simply runs on Verilator alone (icarus tests then skip with
# a reason). Usage from .ci/run:  bash sim/install_iverilog.sh || true
set -u
if command -v iverilog >/dev/null 2>&1 && command -v vvp >/dev/null 2>&1; then
    echo "install_iverilog: $(iverilog -V 2>/dev/null | head -n1)"
    exit 0
fi
if ! command -v apt-get >/dev/null 2>&1; then
    echo "install_iverilog: no apt-get here; Icarus tests will skip"; exit 0
fi
SUDO=""
if [ "$(id -u)" != "0" ]; then
    if command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then SUDO="sudo -n"; else
        echo "install_iverilog: not root and no passwordless sudo; Icarus tests will skip"; exit 0
    fi
fi
export DEBIAN_FRONTEND=noninteractive
if ! $SUDO timeout 180 apt-get install -y -qq --no-install-recommends iverilog >/dev/null 2>&1; then
    $SUDO timeout 180 apt-get update -qq >/dev/null 2>&1 || true
    $SUDO timeout 240 apt-get install -y -qq --no-install-recommends iverilog >/dev/null 2>&1 || true
fi
if command -v iverilog >/dev/null 2>&1; then
    echo "install_iverilog: installed $(iverilog -V 2>/dev/null | head -n1)"
else
    echo "install_iverilog: could not install iverilog; Icarus tests will skip"
fi
exit 0
