#!/usr/bin/env bash
# Renders every image of the README's gallery with the exact commands the
# README prints next to it (renders are bit-identical whatever the thread
# count, so any machine gives the same PNGs). Run from the repository root:
#
#     bash scripts/gallery.sh [NAME...]      # all, or e.g. cbox dof
#
# LENTE picks the binary (default: target/release/lente, built if missing);
# GALLERY_OUT the folder (default docs/images). dof-denoised needs Open
# Image Denoise (pip install pyoidn, or LENTE_OIDN_LIB). The EXRs land beside the
# PNGs and are not kept in git. Times on 2 cores: the small ones a few
# seconds to a minute each; the gallery-size showcases (1600x1200, 1024 spp) about 6 minutes each.
set -euo pipefail
cd "$(dirname "$0")/.."
LENTE=${LENTE:-target/release/lente}
OUT=${GALLERY_OUT:-docs/images}
[ -x "$LENTE" ] || cargo build --release --bin lente
mkdir -p "$OUT"

render() { # NAME ARGS...: one gallery image
    local name=$1
    shift
    echo "== $name: lente render $*" >&2
    "$LENTE" render "$@" -o "$OUT/$name" --progress none
}

gallery() {
    case $1 in
    showcase-mirror-preview) render "$1" scenes/showcase/showcase-mirror.xml ;;
    cbox) render "$1" scenes/cbox/cbox.xml ;;
    dof) render "$1" scenes/dof/dof.xml --spp 256 ;;
    dof-pinhole) render "$1" scenes/dof/dof-pinhole.xml --spp 256 ;;
    dof-denoised) render "$1" scenes/dof/dof.xml --spp 16 --denoise ;;
    dof-16spp) render "$1" scenes/dof/dof.xml --spp 16 ;;
    envmap-mats) render "$1" scenes/envmap/envmap-mats.xml --spp 112 ;;
    envmap-mis) render "$1" scenes/envmap/envmap.xml --spp 64 ;;
    showcase-mirror) render "$1" scenes/showcase/showcase-mirror.xml --resolution 1600x1200 --spp 1024 ;;
    showcase-glass) render "$1" scenes/showcase/showcase-glass.xml --resolution 1600x1200 --spp 1024 ;;
    *)
        echo "unknown gallery image '$1'" >&2
        exit 2
        ;;
    esac
}

ALL=(showcase-mirror-preview cbox dof dof-pinhole dof-denoised dof-16spp envmap-mats envmap-mis showcase-mirror showcase-glass)
for name in "${@:-${ALL[@]}}"; do
    gallery "$name"
done
