#!/usr/bin/env bash
# Numbers on the command line are decimal, as in scene files: CLI11 alone read "--spp 0x10" as
# 16 passes, "--seed 010" as seed 8 (octal), " 5" as 5 and "--exposure 0x1p2" as 4. Every
# subcommand's and daemon's numeric options refuse the other spellings (through expect_error.sh:
# exit 1, the option and the value named), and leading zeros are decimal: --spp 017 --seed 010
# gives the bytes of --spp 17 --seed 10.
# Usage: decimal_options.sh ALPHORN COORDINATOR WORKER EXPECT_ERROR SCENES_DIR
set -eu
alphorn=$1
coordinator=$2
worker=$3
expect_error=$4
scenes=$5
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
scene=$scenes/ok_normals.xml
daemon_files=(--state-dir "$out/no_such_state" --client-token-file "$out/c" --worker-token-file "$out/w")
worker_files=(--coordinator 127.0.0.1:1 --token-file "$out/t" --cache-dir "$out/no_such_cache")
refused() {  # program, option name, value, arguments with the value in place
  local program=$1 name=$2 value=$3
  shift 3
  "$expect_error" "$program" "$name: expected|got $value" -- "$@" >"$out/log" ||
    { cat "$out/log"; fail "$name $value was not refused as it should be"; }
  echo "ok   $name \"$value\" refused"
}
for value in 0x10 0X10 0b11 1e3 +5 " 5" "5 " 5.0 0x; do
  refused "$alphorn" --spp "$value" render "$scene" --spp "$value"
done
refused "$alphorn" --passes 0x4 render "$scene" --passes 0x4
refused "$alphorn" --threads 0x2 render "$scene" --threads 0x2
refused "$alphorn" --tile 0x20 render "$scene" --tile 0x20
refused "$alphorn" --seed 0x7 render "$scene" --seed 0x7
refused "$alphorn" --max-passes 0x40 render "$scene" --target-error 0.1 --max-passes 0x40
refused "$alphorn" --spp 0x10 submit "$scene" --spp 0x10
refused "$alphorn" --priority 0x1 submit "$scene" --priority 0x1
refused "$alphorn" --tile 0x20 submit "$scene" --tile 0x20
refused "$alphorn" --passes-per-unit 0x2 submit "$scene" --passes-per-unit 0x2
refused "$alphorn" job 0x10 status 0x10
refused "$alphorn" job 0x3 retry 0x3
refused "$alphorn" priority 0x3 priority 1 0x3
refused "$alphorn" worker 0x2 drain 0x2
refused "$alphorn" --workers 0x2 cluster --workers 0x2
refused "$alphorn" --threads 0x1 cluster --threads 0x1
refused "$alphorn" --threads 0x1 test "$scene" --threads 0x1
refused "$coordinator" --max-attempts 0x5 "${daemon_files[@]}" --max-attempts 0x5
refused "$coordinator" --max-passes 0x5 "${daemon_files[@]}" --max-passes 0x5
refused "$coordinator" --max-blob-bytes 0x5 "${daemon_files[@]}" --max-blob-bytes 0x5
refused "$worker" --threads 0x2 "${worker_files[@]}" --threads 0x2
# Negative values of an unsigned option were wrapped to 2^64 - 1, values beyond 64 bits saturated.
refused "$alphorn" --spp -1 render "$scene" --spp -1
refused "$coordinator" --max-blob-bytes 18446744073709551616 "${daemon_files[@]}" \
  --max-blob-bytes 18446744073709551616
# Sizes: the number before the unit is decimal too; --crop took " 5" and wrapped 4294967297 to 1.
"$expect_error" "$alphorn" "--max-memory: a size is a number of bytes in decimal digits|got 0x10GB" \
  -- render "$scene" --max-memory 0x10GB >"$out/log" || { cat "$out/log"; fail "--max-memory 0x10GB"; }
"$expect_error" "$alphorn" "--crop 0,0,4294967297,1: expected X0,Y0,X1,Y1" \
  -- render "$scene" --size 8x8 --crop 0,0,4294967297,1 >"$out/log" || { cat "$out/log"; fail "--crop"; }
echo "ok   sizes and --crop refuse the other spellings"
# Fractional options: decimal notation with an optional exponent; strtold also took hex floats,
# a '+' and spaces (nan and inf are refused as not finite: cli.bad_input's *_nan tests).
for value in 0x1p2 +2 " 2" "2 " . 1e 1.5e+ 2,5 0x; do
  refused "$alphorn" --exposure "$value" render "$scene" --exposure "$value"
done
refused "$alphorn" --time-limit 0x10 render "$scene" --time-limit 0x10
refused "$alphorn" --reconnect-seconds 0x3 status --reconnect-seconds 0x3
refused "$coordinator" --lease-seconds 0x5 "${daemon_files[@]}" --lease-seconds 0x5
refused "$worker" --drain-seconds +5 "${worker_files[@]}" --drain-seconds +5
for value in 0.5 -1.5 2e-1 .5 3. 1E0; do
  timeout 60 "$alphorn" render "$scene" -o "$out/frac.exr" --size 8x8 --spp 1 --exposure "$value" \
    2>"$out/frac.log" || { cat "$out/frac.log"; fail "--exposure $value was refused"; }
done
echo "ok   fractional options take decimal notation, with exponents"

render() {  # name, arguments
  local name=$1
  shift
  timeout 120 "$alphorn" render "$scene" -o "$out/$name.exr" --size 8x8 "$@" 2>"$out/$name.log" ||
    { cat "$out/$name.log"; fail "render $name failed"; }
}
render plain --spp 17 --seed 10
render zeros --spp 017 --seed 010
cmp "$out/plain.exr" "$out/zeros.exr" || fail "--spp 017 --seed 010 differs from --spp 17 --seed 10"
echo "ok   leading zeros are decimal"
