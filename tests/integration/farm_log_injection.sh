#!/usr/bin/env bash
# Text from users cannot forge or flood the daemons' logs. A job name, a worker name and scene
# property names (which both daemons repeat in the warning that the property is not used) carry
# quotes, '=', a Unicode line separator, a bidirectional override and a newline followed by a
# whole forged `job.ended` line; a scene has a 5 MB property name. Every line of the
# coordinator's and the workers' logs must then parse as exactly one event (the parser below:
# `ts=` first, key=value fields, values bare or quoted with the formatter's escapes), no value may
# pass the cap of 1024 bytes and its cut marker, the forged line must not appear as an event,
# the names must read back exactly, and the 5 MB name must be logged cut, the daemons still up.
source "$(dirname "$0")/farm_lib.sh"
chmod 600 "$WORK"/*.token

forged_line='ts=2026-01-01T00:00:00.000Z level=info event=job.ended job=1 state=done'
start_coordinator
start_worker 'w "quoted" =x 漢字'
quoted_worker=$WORKER_PID
start_worker b

mkdir -p "$WORK/scene"
cp "$SCENES/../../../scenes/meshes/sphere.obj" "$WORK/scene/sphere.obj"
# write_scene FILE PROPERTY_NAME: a small normals scene whose integrator has an unused property
# named PROPERTY_NAME (XML-escaped by the caller).
write_scene() {
    {
        printf '<scene>\n  <integrator type="normals"><float name="%s" value="1"/></integrator>\n' "$2"
        printf '  <sampler type="independent"><integer name="sampleCount" value="2"/></sampler>\n'
        printf '  <camera type="perspective">\n'
        printf '    <transform name="toWorld"><lookat origin="3, 2, 4" target="0, 0, 0" up="0, 1, 0"/></transform>\n'
        printf '    <integer name="width" value="32"/><integer name="height" value="24"/>\n  </camera>\n'
        printf '  <mesh type="obj"><string name="filename" value="sphere.obj"/></mesh>\n</scene>\n'
    } >"$1"
}
# &#10; is a newline in an XML attribute, &#x2028; the line separator, &#x202e; a right-to-left
# override.
write_scene "$WORK/scene/forged.xml" "x&#10;$forged_line &#x2028; &#x202e;gnp.exe &quot;q&quot;=1"
huge_name=$(head -c $((5 << 20)) /dev/zero | tr '\0' 'A')
write_scene "$WORK/scene/huge.xml" "$huge_name"

# A newline in a job name is refused (names hold no control characters), naming the reason.
if "$ALPHORN" submit "$WORK/scene/forged.xml" --name $'job\n'"$forged_line" --passes 1 \
    >"$WORK/out.txt" 2>&1; then
    fail "a job name with a newline was accepted"
fi
grep -q "control character" "$WORK/out.txt" || fail "unclear refusal: $(cat "$WORK/out.txt")"
pass "a job name with a newline is refused: $(tail -n1 "$WORK/out.txt")"

# Names that are valid but full of what a naive formatter gets wrong are accepted and logged.
line_separator=$'\xe2\x80\xa8' right_to_left=$'\xe2\x80\xae'
job_name="quote\" event=job.ended job=1 state=done $line_separator $right_to_left back\\slash"
forged_job=$("$ALPHORN" submit "$WORK/scene/forged.xml" --name "$job_name" --passes 2 --tile 16 \
    2>>"$WORK/submit.log") || fail "the forged scene was refused: $(cat "$WORK/submit.log")"
if "$ALPHORN" submit "$WORK/scene/huge.xml" --name huge --passes 1 --tile 16 \
    >"$WORK/huge.txt" 2>&1; then
    huge_job=$(tail -n1 "$WORK/huge.txt")
    pass "the scene with a 5 MB property name was accepted as job $huge_job"
else
    huge_job=""
    pass "the scene with a 5 MB property name was refused: $(tail -n1 "$WORK/huge.txt" | cut -c1-200)"
fi
for job in $forged_job $huge_job; do
    timeout 120 "$ALPHORN" watch "$job" >/dev/null 2>"$WORK/watch.log" ||
        fail "job $job did not finish: $(tail -n2 "$WORK/watch.log")"
done
"$ALPHORN" status >/dev/null 2>"$WORK/status.log" || fail "status failed: $(cat "$WORK/status.log")"
kill -0 "$COORDINATOR_PID" 2>/dev/null || fail "the coordinator died"
kill -0 "$quoted_worker" 2>/dev/null || fail "the worker with the quoted name died"
kill -0 "$WORKER_PID" 2>/dev/null || fail "worker b died"
pass "both jobs ended, the daemons are up"

# Every line of every log is one event. The checks print what they found, one word a line.
/usr/bin/python3 - "$WORK" "$job_name" 'w "quoted" =x 漢字' "x
$forged_line $line_separator ${right_to_left}gnp.exe \"q\"=1" >"$WORK/parsed.txt" <<'PY' || fail "$(cat "$WORK/parsed.txt")"
import glob, re, sys
work, job_name, worker_name, property_name = sys.argv[1:5]
MAX_VALUE = 1024
KEY = re.compile(rb'[A-Za-z0-9._-]+')
ESCAPES = {ord('n'): b'\n', ord('r'): b'\r', ord('t'): b'\t', ord('"'): b'"', ord('\\'): b'\\'}

def parse(line):
    """The fields of a log line as (key, value bytes, written length), or an error string."""
    fields, i = [], 0
    if not line.startswith(b'ts='):
        return 'does not start with ts='
    while i < len(line):
        if fields:
            if line[i:i + 1] != b' ':
                return f'no space before field {len(fields)} at byte {i}'
            i += 1
        key = KEY.match(line, i)
        if not key or line[key.end():key.end() + 1] != b'=':
            return f'no key=value at byte {i}'
        i = key.end() + 1
        start = i
        if line[i:i + 1] == b'"':
            value, i = b'', i + 1
            while True:
                if i >= len(line):
                    return 'unterminated quoted value'
                c = line[i]
                if c == ord('"'):
                    i += 1
                    break
                if c < 0x20 or c == 0x7f:
                    return f'raw control byte {c:#x} in a value'
                if c == ord('\\'):
                    e = line[i + 1:i + 2]
                    if e == b'x' and re.fullmatch(rb'[0-9a-f]{2}', line[i + 2:i + 4]):
                        value += bytes([int(line[i + 2:i + 4], 16)])
                        i += 4
                    elif e and e[0] in ESCAPES:
                        value += ESCAPES[e[0]]
                        i += 2
                    else:
                        return f'bad escape at byte {i}'
                else:
                    value += bytes([c])
                    i += 1
        else:
            bare = re.compile(rb'[^ "=\\\x00-\x20\x7f]+').match(line, i)
            if not bare:
                return f'empty or bad bare value at byte {i}'
            value, i = bare.group(0), bare.end()
        fields.append((key.group(0).decode(), value, i - start))
    return fields

logs = sorted(glob.glob(work + '/coordinator.log') + glob.glob(work + '/worker-*.log'))
bad, events = [], []
for log in logs:
    with open(log, 'rb') as f:
        data = f.read()
    if data and not data.endswith(b'\n'):
        bad.append(f'{log}: does not end with a newline')
    for number, line in enumerate(data.split(b'\n')[:-1], 1):
        fields = parse(line)
        where = f'{log}:{number}'
        if isinstance(fields, str):
            bad.append(f'{where}: {fields}: {line[:300]!r}')
            continue
        keys = [k for k, _, _ in fields]
        if keys.count('event') != 1:
            bad.append(f'{where}: {keys.count("event")} event= fields: {line[:300]!r}')
        for key, value, written in fields:
            # The written value: its quotes, at most MAX_VALUE bytes, and the cut marker.
            if written > MAX_VALUE + 2 + len('...[99999999999 bytes cut]'):
                bad.append(f'{where}: {key}= is {written} bytes long')
        if len(line) > 8192:
            bad.append(f'{where}: the line is {len(line)} bytes long')
        events.append((log, dict((k, v) for k, v, _ in fields), line))
if bad:
    print('\n'.join(bad[:20]))
    sys.exit(1)
if any(f['ts'] == b'2026-01-01T00:00:00.000Z' for _, f, _ in events):
    print('the forged line appears as an event')
    sys.exit(1)

def found(condition, what):
    if not any(condition(log, f) for log, f, _ in events):
        print('no line found: ' + what)
        sys.exit(1)
    print('found: ' + what)

found(lambda log, f: f.get('event') == b'job.submitted' and f.get('name') == job_name.encode(),
      'job.submitted with the job name read back exactly')
found(lambda log, f: log.endswith('coordinator.log') and f.get('event') == b'worker.registered'
      and worker_name.encode() in b' '.join(f.values()), 'the quoted worker name in worker.registered')
for daemon in ('coordinator.log', 'worker-'):
    found(lambda log, f: daemon in log and f.get('event') == b'warning'
          and ('"' + property_name + '"').encode() in f.get('message', b''),
          f'{daemon}: the forged property name read back exactly in its warning')
found(lambda log, f: log.endswith('coordinator.log') and f.get('event') == b'warning'
      and re.search(rb'"A{100,}\.\.\.\[[0-9]+ bytes cut\]$', f.get('message', b'')) is not None,
      "the 5 MB property name's warning, cut")
print(f'{len(events)} lines in {len(logs)} logs, each one event')
PY
while read -r line; do pass "$line"; done <"$WORK/parsed.txt"
echo "PASS"
