#!/usr/bin/env python3
"""Runs the shell steps of docs/operations.md as written, in order, on this machine.

Usage: operations_doc_test.py DOC SOURCE_DIR BIN_DIR...

The guide's conventions (described in its section "How this guide is tested"), which this test
enforces:

- Every code block names its language. Shell blocks (```sh) are run; the others (text, ini,
  yaml) are not. A block without a language fails the test, so a command cannot escape by an
  untagged fence.
- A shell block is skipped only when the line right before it is
  <!-- ops-test: skip (REASON) --> with a REASON of SKIP_REASONS. Any other ops-test marker fails.
- A line made only of assignments to the guide's variables (PREFIX_VARIABLES) runs with this
  test's values: the host is `localhost`, the directories are under a temporary directory.
- The guide's port (GUIDE_PORTS) is replaced by a free one in the commands run, so that copies of
  this test (two checkouts testing at once) do not collide: `--listen HOST:7700` becomes
  `--listen HOST:0 --port-file FILE` (the coordinator picks a free port and records it; the test
  waits for the file), and every other `:7700` names the port it picked.
- A command that runs until stopped (the daemons, `alphorn cluster` without --render) runs in the
  background, as in a second terminal. If one exits before the end, the test fails at once; at the
  end each gets SIGTERM, which the guide says stops it with exit code 0, and must do so.

Every other line runs as written, in one bash session (so variables carry over from block to
block, as in the reader's terminal) with `set -euo pipefail`: any failing command fails the test.
The working directory stands for the checkout (a temporary directory with a link to its
scenes/), PATH starts with the build tree's binaries, HOME and TMPDIR are temporary, and no
ALPHORN_* variable of the caller's environment is passed on (a fresh machine has none).
"""
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time

SKIP_REASONS = {
    "multi-host": "needs other machines",
    "systemd": "needs systemd and root",
    "docker": "needs Docker and root; tests/deploy/docker_cluster.sh runs these steps",
    "fuzzing": "needs the fuzz build tree and minutes; tools/run-tests.sh runs tools/fuzz.sh --smoke",
}
SHELL_LANGUAGES = {"sh", "bash", "shell"}
OTHER_LANGUAGES = {"text", "ini", "yaml", "json", "toml"}
PREFIX_VARIABLES = ("FARM", "CONF", "STATE", "CACHE", "BACKUP")
# The ports the guide's daemons listen on, replaced by free ones in the commands run
# (move_guide_ports): a fixed port would fail two copies of the test run at once.
GUIDE_PORTS = (7700,)
# How long the test waits for a coordinator started on a free port to record it.
PORT_FILE_WAIT_SECONDS = 15
TIME_LIMIT_SECONDS = 120
STOP_LIMIT_SECONDS = 30


def fail(message):
    print("FAIL: " + message, file=sys.stderr)
    sys.exit(1)


def extract_blocks(doc_path):
    """Returns [(first line number, language, skip reason or None, [(line number, text)])]."""
    with open(doc_path, encoding="utf-8") as doc:
        lines = doc.read().split("\n")
    blocks, block, marker, previous = [], None, None, ""
    marker_pattern = re.compile(r"^<!-- ops-test: (.*) -->$")
    for number, line in enumerate(lines, start=1):
        if block is not None:
            if line.startswith("```"):
                blocks.append(block)
                block = None
            else:
                block[3].append((number, line))
            continue
        if line.startswith("```"):
            language = line[3:].strip()
            if not language:
                fail(f"{doc_path}:{number}: a code block without a language: shell blocks are "
                     "```sh, others name theirs (```text, ```ini, ```yaml)")
            if language not in SHELL_LANGUAGES | OTHER_LANGUAGES:
                fail(f"{doc_path}:{number}: unknown code block language {language!r}")
            reason = None
            found = marker_pattern.match(previous)
            if found:
                skip = re.fullmatch(r"skip \(([^)]*)\)", found.group(1))
                if not skip or skip.group(1) not in SKIP_REASONS:
                    fail(f"{doc_path}:{number - 1}: unknown marker {previous!r}; a shell block "
                         "is skipped only by <!-- ops-test: skip (REASON) --> with a REASON of: "
                         + ", ".join(SKIP_REASONS))
                if language not in SHELL_LANGUAGES:
                    fail(f"{doc_path}:{number - 1}: a skip marker before a {language} block")
                reason = skip.group(1)
            block = (number, language, reason, [])
        elif line.startswith("<!--") and "ops-test" in line and not marker_pattern.match(line):
            fail(f"{doc_path}:{number}: a malformed ops-test marker: {line!r}")
        elif marker_pattern.match(previous) and line.strip():
            fail(f"{doc_path}:{number - 1}: an ops-test marker not right before a code block")
        previous = line
    if block is not None:
        fail(f"{doc_path}:{block[0]}: the code block is never closed")
    return blocks


def commands(block_lines):
    """Joins continuation lines: [(first line number, [physical lines])]."""
    result, current = [], None
    for number, text in block_lines:
        if current is None:
            if not text.strip():
                continue
            current = (number, [])
        current[1].append(text)
        if not text.rstrip().endswith("\\"):
            result.append(current)
            current = None
    if current is not None:
        result.append(current)
    return result


SETTINGS_LINE = re.compile(r"^\s*(?:[A-Za-z_][A-Za-z0-9_]*=\S*\s+)*[A-Za-z_][A-Za-z0-9_]*=\S*\s*(?:#.*)?$")


def is_settings_line(text):
    if not SETTINGS_LINE.match(text):
        return False
    names = re.findall(r"([A-Za-z_][A-Za-z0-9_]*)=", text.split("#")[0])
    return all(name in PREFIX_VARIABLES for name in names)


def runs_until_stopped(text):
    words = text.split()
    if not words:
        return False
    if words[0] in ("alphorn-coordinator", "alphorn-worker"):
        return True
    return words[:2] == ["alphorn", "cluster"] and "--render" not in text


def port_file(port):
    return f'"$WORK/port-{port}"'


def move_guide_ports(text):
    """Returns (the command with the guide's ports replaced by free ones, the guide ports it
    listens on). A `--listen HOST:PORT` becomes `--listen HOST:0 --port-file FILE`; any other
    `:PORT` becomes `:$GUIDE_PORT_PORT`, which the script sets from that file once the daemon
    listening on it has written it."""
    listened = []
    for port in GUIDE_PORTS:
        text, count = re.subn(rf"(--listen[ =]\S*?):{port}\b",
                              rf"\1:0 --port-file {port_file(port)}", text)
        if count:
            listened.append(port)
        text = re.sub(rf":{port}\b", f":$GUIDE_PORT_{port}", text)
    return text, listened


def build_script(doc_path, blocks, values):
    shown_doc = shlex.quote(doc_path)
    out = ["set -euo pipefail", "DAEMONS=()", f"DOC_NAME={shown_doc}",
           f'trap \'echo "FAIL: "{shown_doc}":$DOC_LINE: exit status $?" >&2\' ERR']
    for name in PREFIX_VARIABLES:
        out.append(f"{name}={shlex.quote(values[name])}")
    ran = skipped = 0
    for first, language, reason, block_lines in blocks:
        if language not in SHELL_LANGUAGES:
            continue
        if reason is not None:
            print(f"skip {os.path.basename(doc_path)}:{first}: {reason} ({SKIP_REASONS[reason]})")
            skipped += 1
            continue
        ran += 1
        out.append(f"echo '== block at line {first}'")
        for number, physical in commands(block_lines):
            text = "\n".join(physical)
            out.append(f"DOC_LINE={number}")
            if is_settings_line(text):
                names = re.findall(r"([A-Za-z_][A-Za-z0-9_]*)=", text.split("#")[0])
                shown = " ".join(f"{name}={values[name]}" for name in names)
                out.append(f"echo {shlex.quote(f'line {number}: the guide sets its variables; this test: {shown}')}")
                continue
            text, listened = move_guide_ports(text)
            for port in listened:
                out.append(f"rm -f {port_file(port)}")  # a daemon started again records anew
            out.append(f"echo {shlex.quote(f'+ line {number}: {text}')}")
            if runs_until_stopped(text):
                log = f"$WORK/daemon-line{number}.log"
                # exec: the daemon itself is the background process that SIGTERM reaches.
                out.append("{ exec " + text + "\n} >" + log + " 2>&1 &")
                out.append(f'DAEMONS+=($!); echo "$! {number} {log}" >>"$WORK/daemons"')
            else:
                out.append(text)
            for port in listened:
                # The guide's next commands connect to it: wait until it listens.
                out.append(f"for _ in $(seq {PORT_FILE_WAIT_SECONDS * 20}); do "
                           f"[[ -s {port_file(port)} ]] && break; sleep 0.05; done")
                out.append(f"[[ -s {port_file(port)} ]] || {{ echo \"FAIL: $DOC_NAME:{number}: "
                           f"no port recorded within {PORT_FILE_WAIT_SECONDS} s\" >&2; exit 1; }}")
                out.append(f"GUIDE_PORT_{port}=$(cat {port_file(port)})")
                out.append(f"echo 'line {number}: the guide port {port} is '\"$GUIDE_PORT_{port}\""
                           "' in this test'")
    out.append("DOC_LINE=end")
    # Stop the daemons last started first (workers before their coordinator), as the guide says:
    # SIGTERM, exit code 0.
    out.append(f"DOC={shown_doc}")
    out.append(r"""
touch "$WORK/stopping"
for ((i = ${#DAEMONS[@]} - 1; i >= 0; --i)); do
    pid=${DAEMONS[i]}
    kill -TERM "$pid"
    status=0
    wait "$pid" || status=$?
    line=$(grep "^$pid " "$WORK/daemons" | cut -d' ' -f2)
    echo "stopped the daemon of line $line (pid $pid) with SIGTERM: exit status $status"
    [[ $status -eq 0 ]] || { echo "FAIL: $DOC:$line: exit status $status after SIGTERM, not 0" >&2; exit 1; }
done
echo "ALL STEPS RAN"
""")
    return "\n".join(out) + "\n", ran, skipped


def process_is_gone(pid):
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().rsplit(")", 1)[1].split()[0] in ("Z", "X")
    except FileNotFoundError:
        return True


def copy_output(source, log):
    for line in iter(source.readline, b""):
        text = line.decode(errors="replace")
        sys.stdout.write(text)
        sys.stdout.flush()
        log.write(text)


def remove_cluster_logs(work):
    """`alphorn cluster` keeps its logs in /tmp/alphorn-cluster-*, as the guide says; a passing
    run removes the folders its steps' clusters named."""
    for name in os.listdir(work):
        if name.endswith(".log"):
            with open(os.path.join(work, name), errors="replace") as log:
                for folder in set(re.findall(r"logs (?:kept )?in (/tmp/alphorn-cluster-[A-Za-z0-9]+)",
                                             log.read())):
                    shutil.rmtree(folder, ignore_errors=True)


def show_logs(work):
    for name in sorted(os.listdir(work)):
        if name.endswith(".log"):
            with open(os.path.join(work, name), errors="replace") as log:
                tail = log.read().splitlines()[-20:]
            print(f"== {name}\n" + "\n".join(tail))


def main():
    if len(sys.argv) < 4:
        fail("usage: operations_doc_test.py DOC SOURCE_DIR BIN_DIR...")
    doc_path, source_dir, bin_dirs = sys.argv[1], sys.argv[2], sys.argv[3:]
    blocks = extract_blocks(doc_path)

    work = tempfile.mkdtemp(prefix="alphorn-ops-test-")
    checkout = os.path.join(work, "checkout")
    for directory in (checkout, os.path.join(work, "home"), os.path.join(work, "tmp")):
        os.makedirs(directory)
    os.symlink(os.path.join(os.path.abspath(source_dir), "scenes"), os.path.join(checkout, "scenes"))
    values = {"FARM": "localhost", "CONF": f"{work}/etc/alphorn", "STATE": f"{work}/var/lib/alphorn",
              "CACHE": f"{work}/var/cache/alphorn", "BACKUP": f"{work}/backup"}
    script, ran, skipped = build_script(doc_path, blocks, values)
    script = f"WORK={shlex.quote(work)}\n" + script
    with open(os.path.join(work, "steps.sh"), "w") as file:
        file.write(script)

    environment = {key: value for key, value in os.environ.items()
                   if not key.startswith("ALPHORN_") and key != "XDG_CONFIG_HOME"}
    environment.update(
        PATH=":".join(os.path.abspath(d) for d in bin_dirs) + ":" + os.environ.get("PATH", ""),
        HOME=os.path.join(work, "home"), TMPDIR=os.path.join(work, "tmp"))
    start = time.monotonic()
    steps_log = open(os.path.join(work, "steps.log"), "w")
    shell = subprocess.Popen(["bash", os.path.join(work, "steps.sh")], cwd=checkout,
                             env=environment, start_new_session=True, stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT)
    # Echo the steps' output and keep it (for the cluster's log folders, removed at the end).
    copier = threading.Thread(target=copy_output, args=(shell.stdout, steps_log), daemon=True)
    copier.start()
    problem = None
    daemons_file = os.path.join(work, "daemons")
    try:
        while shell.poll() is None:
            if time.monotonic() - start > TIME_LIMIT_SECONDS:
                problem = f"the steps took more than {TIME_LIMIT_SECONDS} s"
                break
            if os.path.exists(daemons_file):
                with open(daemons_file) as file:
                    for entry in file.read().split("\n"):
                        if not entry:
                            continue
                        pid, line, _ = entry.split(" ", 2)
                        # At the end the script stops them and checks their exit status;
                        # before that, an exit is a failure (a bad flag, a port in use).
                        if process_is_gone(int(pid)) and not os.path.exists(
                                os.path.join(work, "stopping")):
                            problem = (f"{doc_path}:{line}: the command that should run "
                                       "until stopped exited early")
                if problem:
                    break
            if shell.poll() is None:
                time.sleep(0.1)
    finally:
        if shell.poll() is None:
            os.killpg(shell.pid, signal.SIGKILL)
            shell.wait()
        try:
            os.killpg(shell.pid, signal.SIGKILL)  # anything the steps left behind
        except ProcessLookupError:
            pass
    copier.join(timeout=5)
    steps_log.close()
    if problem is None and shell.returncode != 0:
        problem = f"the steps failed (exit status {shell.returncode}); see above"
    if problem:
        show_logs(work)
        fail(problem + f"; the steps and logs are in {work}")
    remove_cluster_logs(work)
    shutil.rmtree(work, ignore_errors=True)
    print(f"PASS: {ran} shell blocks of {os.path.basename(doc_path)} ran, {skipped} skipped "
          f"(marked), in {time.monotonic() - start:.1f} s")


if __name__ == "__main__":
    main()
