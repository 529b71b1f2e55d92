#!/usr/bin/env bash
# Runs lente's fuzz targets, each for SECONDS (default 60), on the nightly
# toolchain with cargo-fuzz (installed from crates.io if missing).
#
#   fuzz/run.sh [SECONDS] [TARGET...]     all targets when none is named
#
# Each target's corpus (fuzz/corpus/TARGET, not committed) starts from the
# repository's own files of its kind and the small images in fuzz/seeds/.
# A crash, abort, leak of more than 2 GiB, or an input that takes more than
# 10 s stops that target with the input saved under fuzz/artifacts/TARGET/;
# the script then exits non-zero. Minimise it (cargo +nightly fuzz tmin),
# fix the cause, and add the input to fuzz/regressions/TARGET/, which the
# stable test suite replays (tests/integration/fuzz_regressions.rs).
#
# FUZZ_SANITIZER=address builds with AddressSanitizer (slower to build and
# run; default none: lente has no unsafe code of its own, and panics,
# aborts, timeouts and the memory limit are caught either way).
#
# FUZZ_JOBS targets run at once (default: one per CPU core; each libFuzzer
# process is single-threaded), after one build of them all, so every
# target still gets its SECONDS and the run takes a core count's fraction
# of the time.
set -euo pipefail
cd "$(dirname "$0")/.."
SECONDS_EACH="${1:-60}"
shift || true
TARGETS=("$@")
if [ ${#TARGETS[@]} -eq 0 ]; then
    TARGETS=(nori_scene mitsuba_scene nori_test obj ply serialized vol curve hdr pfm exr png jpeg bmp)
fi
SANITIZER="${FUZZ_SANITIZER:-none}"

if ! cargo fuzz --version >/dev/null 2>&1; then
    cargo install cargo-fuzz --locked
fi

# seed TARGET FILE...: copies the files (at most 256 KiB each) into the
# target's corpus.
seed() {
    local dir="fuzz/corpus/$1"
    shift
    mkdir -p "$dir"
    for f in "$@"; do
        if [ -f "$f" ] && [ "$(stat -c %s "$f")" -le 262144 ]; then
            cp "$f" "$dir/$(echo "$f" | tr / _)"
        fi
    done
}
xml_with_root() { # ROOT PATTERN...: the XML files whose root element is ROOT
    local root="$1"
    shift
    grep -l -m1 "<$root[ >]" "$@" 2>/dev/null || true
}
seed_target() {
    case "$1" in
    nori_scene) seed "$1" $(xml_with_root scene scenes/*/*.xml tests/scenes/*.xml | xargs grep -L 'version=' || true) ;;
    mitsuba_scene) seed "$1" $(grep -l '<scene version=' scenes/*/*.xml tests/conformance/*.xml bench/speed/constant_cube.xml || true) ;;
    nori_test) seed "$1" $(xml_with_root test tests/scenes/*.xml) ;;
    obj) seed "$1" $(git ls-files '*.obj') ;;
    ply) seed "$1" $(git ls-files '*.ply') ;;
    serialized) seed "$1" $(git ls-files '*.serialized') ;;
    vol) seed "$1" $(git ls-files '*.vol') ;;
    curve) seed "$1" tests/conformance/polyline.txt tests/conformance/wave.txt tests/conformance/arc.txt ;;
    pfm) seed "$1" $(git ls-files '*.pfm') ;;
    hdr | exr | png | jpeg | bmp) seed "$1" fuzz/seeds/"$1"/* ;;
    *)
        echo "unknown fuzz target '$1'" >&2
        exit 2
        ;;
    esac
}

JOBS="${FUZZ_JOBS:-$(nproc)}"
for t in "${TARGETS[@]}"; do
    seed_target "$t"
    mkdir -p "fuzz/artifacts/$t"
done
# One build of the targets (all in one cargo call when none was named);
# the runs below find it up to date.
if [ $# -eq 0 ]; then
    cargo +nightly fuzz build -O --sanitizer "$SANITIZER"
else
    for t in "${TARGETS[@]}"; do
        cargo +nightly fuzz build -O --sanitizer "$SANITIZER" "$t"
    done
fi

# fuzz_one TARGET: fuzzes it for SECONDS_EACH; its log and exit status go
# under fuzz/artifacts/TARGET/.
fuzz_one() {
    local t="$1" rc=0
    cargo +nightly fuzz run -O --sanitizer "$SANITIZER" "$t" "fuzz/corpus/$t" -- \
        -max_total_time="$SECONDS_EACH" -timeout=10 -rss_limit_mb=2048 \
        -max_len=65536 -print_final_stats=1 >"fuzz/artifacts/$t/log.txt" 2>&1 || rc=$?
    echo "$rc" >"fuzz/artifacts/$t/rc"
}

running=0
for t in "${TARGETS[@]}"; do
    echo "== fuzz target $t: ${SECONDS_EACH} s"
    fuzz_one "$t" &
    running=$((running + 1))
    if [ "$running" -ge "$JOBS" ]; then
        wait -n || true
        running=$((running - 1))
    fi
done
wait

failed=()
for t in "${TARGETS[@]}"; do
    log="fuzz/artifacts/$t/log.txt"
    echo "== $t"
    grep -E '^(stat::number_of_executed_units|stat::peak_rss_mb|==[0-9]+== ERROR|SUMMARY|Test unit written)|panicked' "$log" || true
    if [ "$(cat "fuzz/artifacts/$t/rc")" -ne 0 ]; then
        tail -n 30 "$log"
        failed+=("$t")
    fi
done
if [ ${#failed[@]} -gt 0 ]; then
    echo "fuzzing found failures in: ${failed[*]} (inputs under fuzz/artifacts/)" >&2
    exit 1
fi
echo "fuzzing: no failures in ${TARGETS[*]}"
