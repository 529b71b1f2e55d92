#!/usr/bin/env bash
# Checks that the working tree renders every example scene bit-identically
# to revision BASE (default HEAD): both builds of examples/render_digests.rs
# render the scenes of this checkout at a fixed small size, spp and seed,
# and their per-scene digests must agree. For changes that must not alter
# images (refactorings). BASE must contain examples/render_digests.rs.
#
#   scripts/same-images.sh [BASE]
set -euo pipefail
cd "$(dirname "$0")/.."
base=${1:-HEAD}
rev=$(git rev-parse --verify "$base^{commit}")
work=$(mktemp -d)
trap 'git worktree remove --force "$work/tree" >/dev/null 2>&1 || true; rm -rf "$work"' EXIT
git worktree add --quiet --detach "$work/tree" "$rev"
# One target folder for base builds, so a second run rebuilds little.
CARGO_TARGET_DIR="$PWD/target/same-images-base" \
    cargo build --release --quiet --example render_digests --manifest-path "$work/tree/Cargo.toml"
cargo build --release --quiet --example render_digests
"$PWD/target/same-images-base/release/examples/render_digests" "$PWD" >"$work/base.txt"
target/release/examples/render_digests "$PWD" >"$work/new.txt"
scenes=$(grep -c . "$work/new.txt")
if diff -u "$work/base.txt" "$work/new.txt"; then
    echo "same images: $scenes lines agree with $base (${rev:0:10})"
else
    echo "images differ from $base (${rev:0:10}): lines above" >&2
    exit 1
fi
