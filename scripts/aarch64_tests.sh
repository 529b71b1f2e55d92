#!/usr/bin/env bash
# The unit tests (`cargo test --release --lib`) built for aarch64 and run
# under qemu-user: the code paths that x86-64 machines never take (the
# portable BVH walks and node tests, the scalar ray offsets, no AVX2
# lanes) checked by the same tests. About 10 minutes on 2 cores, most of
# it in qemu. Extra arguments go to the test binary (e.g. a name filter).
# Needs Debian's gcc-aarch64-linux-gnu, libc6-arm64-cross and qemu-user
# (installed when missing, as root) and rustup.
set -euo pipefail
cd "$(dirname "$0")/.."
rustup target add aarch64-unknown-linux-gnu
if ! command -v aarch64-linux-gnu-gcc >/dev/null || ! command -v qemu-aarch64 >/dev/null \
    || [ ! -d /usr/aarch64-linux-gnu/lib ]; then
    apt-get update && DEBIAN_FRONTEND=noninteractive apt-get install -y \
        gcc-aarch64-linux-gnu libc6-arm64-cross qemu-user
fi
export CARGO_TARGET_AARCH64_UNKNOWN_LINUX_GNU_LINKER=aarch64-linux-gnu-gcc
export CARGO_TARGET_AARCH64_UNKNOWN_LINUX_GNU_RUNNER="qemu-aarch64 -L /usr/aarch64-linux-gnu"
cargo test --release --lib --target aarch64-unknown-linux-gnu -- "$@"
