#!/usr/bin/env bash
# Installs what the tests need on a fresh Debian machine (idempotent): the Cortex-M4F Rust target and
# LLVM tools, QEMU (the core on the emulated M4F), socat (serial pty pairs), gcc (the QEMU
# instruction-count plugin), a TrueType font for the plots and flip-link (the Cortex-M linker).
set -euo pipefail
need=()
command -v qemu-system-arm >/dev/null || need+=(qemu-system-arm)
command -v socat >/dev/null || need+=(socat)
command -v gcc >/dev/null || need+=(gcc)
[ -e /usr/share/fonts/truetype/dejavu/DejaVuSans.ttf ] || need+=(fonts-dejavu-core)
if [ ${#need[@]} -gt 0 ]; then
  SUDO=""; [ "$(id -u)" = 0 ] || SUDO="sudo"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq "${need[@]}"
fi
rustup target add thumbv7em-none-eabihf
rustup component add llvm-tools clippy rustfmt
# flip-link: the linker of the Cortex-M builds (.cargo/config.toml), stack-overflow protection.
command -v flip-link >/dev/null || cargo install --locked flip-link
