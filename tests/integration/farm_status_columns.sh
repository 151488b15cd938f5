#!/usr/bin/env bash
# `alphorn status` and `alphorn workers` line up names of any script: job and worker names
# mixing ASCII, é (precomposed and as e + a combining accent), 漢字 and an emoji take their
# columns on a terminal, not their bytes, so every row's columns after the name start at the
# same display column. The widths here come from Python's unicodedata (East Asian width, and
# combining marks as zero), independent of the CLI's own.
source "$(dirname "$0")/farm_lib.sh"
chmod 600 "$WORK"/*.token
export USER=tester

precomposed=$'caf\xc3\xa9'          # café, é as one character
combining=$'cafe\xcc\x81'           # café, e + U+0301
kanji=$'\xe6\xbc\xa2\xe5\xad\x97'   # 漢字
emoji=$'\xf0\x9f\x8e\xac'           # 🎬
long=""
for _ in $(seq 25); do long+=$kanji; done  # 100 columns, more than the name column's 40
names=("plain" "$precomposed" "$combining" "$kanji" "$emoji" "$kanji $combining $emoji mix" "$long")
start_coordinator
start_worker "$kanji-$emoji"
start_worker "$combining"
for name in "${names[@]}"; do
    "$ALPHORN" submit "$SCENES/farm_normals.xml" --name "$name" --passes 1 --tile 32 \
        >/dev/null 2>>"$WORK/submit.log" || fail "submit '$name' failed: $(cat "$WORK/submit.log")"
done
"$ALPHORN" status >"$WORK/status.txt" 2>"$WORK/status.log" || fail "status failed: $(cat "$WORK/status.log")"
wait_until 20 bash -c '[[ $("$0" workers | wc -l) -ge 3 ]]' "$ALPHORN"
"$ALPHORN" workers >"$WORK/workers.txt" 2>"$WORK/workers.log" || fail "workers failed: $(cat "$WORK/workers.log")"

# check_columns FILE HEADER start|end: in every row, the cell under HEADER (the column after
# the name: OWNER for jobs, left-aligned; CORES for workers, right-aligned) starts (ends) at the
# display column where HEADER starts (ends).
check_columns() {
    /usr/bin/python3 - "$@" <<'PY'
import sys, unicodedata
path, header_text, edge = sys.argv[1:4]

def width(text):
    return sum(0 if unicodedata.combining(c) else
               2 if unicodedata.east_asian_width(c) in 'WF' else 1 for c in text)

def at(line, column):
    """The character shown at a display column, or ' ' past the end."""
    shown = 0
    for c in line:
        shown += width(c)
        if shown > column:
            return c
    return ' '

lines = open(path, encoding='utf-8').read().splitlines()
header = lines[0]
start = width(header[:header.index(header_text)])
column = start if edge == 'start' else start + width(header_text)
problems = []
for line in lines[1:]:
    inside, outside = (column, column - 1) if edge == 'start' else (column - 1, column)
    if at(line, inside) == ' ' or at(line, outside) != ' ':
        problems.append(f'{line!r}: the cell under {header_text} does not {edge} at column {column}')
if problems:
    print('\n'.join(problems))
    sys.exit(1)
print(f'{len(lines) - 1} rows of {path.rsplit("/", 1)[-1]}: the cells under {header_text} {edge} at column {column}')
PY
}
check_columns "$WORK/status.txt" OWNER start >"$WORK/check.txt" || fail "status misaligned: $(cat "$WORK/check.txt")"
pass "$(cat "$WORK/check.txt")"
check_columns "$WORK/workers.txt" CORES end >"$WORK/check.txt" || fail "workers misaligned: $(cat "$WORK/check.txt")"
pass "$(cat "$WORK/check.txt")"
for name in "${names[@]:0:6}"; do
    grep -qF " $name " "$WORK/status.txt" || fail "the name '$name' is not shown whole: $(cat "$WORK/status.txt")"
done
grep -qF "…" "$WORK/status.txt" || fail "the long name was not cut with an ellipsis"
pass "short names shown whole, the long one cut with an ellipsis"
echo "PASS"
