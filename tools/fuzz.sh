#!/usr/bin/env bash
# Fuzzes Alphorn's input boundaries with libFuzzer (harnesses in fuzz/, one per target).
#   tools/fuzz.sh TARGET SECONDS [SEED]   a session on one target, under nice; TARGET is one of
#                                         scene_parser pbrt_parser obj_loader ply_reader bundle_manifest film_codec checkpoint
#   tools/fuzz.sh --smoke                 every target for a fixed number of runs from a fixed
#                                         seed (ALPHORN_FUZZ_SEED, default 1): the CI stage
# Both build the fuzz tree first (tools/build.sh fuzz, clang + ASan + UBSan). A session starts
# from the committed seeds (fuzz/corpus/TARGET) plus what earlier sessions on this machine found
# (build-fuzz/corpus/TARGET, which grows); the smoke run starts from the seeds alone, so the same
# seed replays the same inputs. A crash stops the run with a non-zero status and leaves the input
# in build-fuzz/artifacts/TARGET/; replay it with build-fuzz/fuzz/fuzz_TARGET FILE.
set -euo pipefail
cd "$(dirname "$0")/.."
TARGETS=(scene_parser pbrt_parser obj_loader ply_reader bundle_manifest film_codec checkpoint)
# Runs per target in the smoke stage: each takes 5-40 s on one core of the CI machine.
declare -A SMOKE_RUNS=([scene_parser]=8000 [pbrt_parser]=8000 [obj_loader]=20000 [ply_reader]=20000
                       [bundle_manifest]=300000 [film_codec]=100000 [checkpoint]=30000)

fuzz_target() {  # TARGET SEED WORK_CORPUS LIBFUZZER_OPTIONS...
  local target=$1 seed=$2 corpus=$3
  shift 3
  local options=(-seed="$seed" -timeout=30 -rss_limit_mb=2048 -print_final_stats=1
                 -artifact_prefix="build-fuzz/artifacts/$target/")
  [ -f "fuzz/$target.dict" ] && options+=(-dict="fuzz/$target.dict")
  mkdir -p "build-fuzz/artifacts/$target" "$corpus"
  echo "== fuzz $target: seed $seed, $*"
  nice "build-fuzz/fuzz/fuzz_$target" "${options[@]}" "$@" "$corpus" "fuzz/corpus/$target"
}

export CCACHE_DIR=${CCACHE_DIR:-$HOME/.cache/alphorn-ccache}
export CCACHE_SLOPPINESS=${CCACHE_SLOPPINESS:-time_macros}
# Findings are failures; leaks are not looked for (Embree and oneTBB keep per-process pools).
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0} UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1}

if [ "${1:-}" = "--smoke" ]; then
  seed=${ALPHORN_FUZZ_SEED:-1}
  tools/build.sh fuzz
  echo "== fuzz smoke: seed $seed (replay with ALPHORN_FUZZ_SEED=$seed tools/fuzz.sh --smoke)"
  # The targets run side by side, as many at once as there are cores (each harness is one
  # process on one core); their reports follow in the targets' order once all have ended.
  logs=$(mktemp -d)
  for target in "${TARGETS[@]}"; do
    while [ "$(jobs -rp | wc -l)" -ge "$(nproc)" ]; do wait -n || true; done
    (
      work=$(mktemp -d)
      status=0
      fuzz_target "$target" "$seed" "$work" -runs="${SMOKE_RUNS[$target]}" \
        >"$logs/$target.log" 2>&1 || status=$?
      echo "$status" >"$logs/$target.status"
      rm -rf "$work"
    ) &
  done
  wait
  failed=0
  for target in "${TARGETS[@]}"; do
    if [ "$(cat "$logs/$target.status")" != 0 ]; then
      tail -n 60 "$logs/$target.log"
      echo "fuzz $target failed (seed $seed); the input is in build-fuzz/artifacts/$target/" >&2
      failed=1
    else
      head -n 1 "$logs/$target.log"
      grep -E "^(stat::number_of_executed_units|stat::peak_rss_mb|Done )" "$logs/$target.log" || true
    fi
  done
  rm -rf "$logs"
  exit "$failed"
fi

if [ $# -lt 2 ] || [[ ! " ${TARGETS[*]} " =~ " $1 " ]]; then
  echo "usage: tools/fuzz.sh TARGET SECONDS [SEED] | --smoke   (TARGET: ${TARGETS[*]})" >&2
  exit 2
fi
target=$1 seconds=$2 seed=${3:-$(date +%s)}
tools/build.sh fuzz
fuzz_target "$target" "$seed" "build-fuzz/corpus/$target" -max_total_time="$seconds"
