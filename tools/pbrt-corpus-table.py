#!/usr/bin/env python3
"""Runs Alphorn on every scene of a copy of the pbrt-v4 scene corpus and writes a Markdown table.

The corpus is the public repository https://github.com/mmp/pbrt-v4-scenes;
tools/fetch-pbrt-v4-scenes.sh brings it (or a local copy of it) to a directory outside this
repository.

Usage:
    tools/pbrt-corpus-table.py CORPUS_DIR [--alphorn PATH] [--out FILE] [--listing FILE]
                               [--timeout SECONDS] [--max-memory SIZE] [--threads N]

A scene file is a .pbrt file that contains WorldBegin; the other .pbrt files are parts that scene
files include. Each scene is rendered at 8x8 pixels and 1 sample per pixel, so Alphorn reads and
builds the whole scene but spends almost no time rendering it. The outcome is one of:
    renders           Alphorn exits 0
    refused           Alphorn's first error names a feature or a value it does not render
    missing files     the first error is a file the scene names that is not in CORPUS_DIR
    over the memory limit, timed out, crashed   the run itself did not finish
Warnings (settings Alphorn ignores) are collected per scene. --listing takes the repository's
full list of .pbrt paths, one per line, so that files absent from a partial copy are listed too.
The default output is docs/pbrt-v4-corpus.md of this repository. Exits 2 on a bad argument (a
CORPUS_DIR that is not a directory or holds no scene file, an Alphorn that does not run).
"""

import argparse
import collections
import datetime
import os
import pathlib
import re
import shlex
import shutil
import subprocess
import sys
import tempfile

REPO_ROOT = pathlib.Path(__file__).resolve().parent.parent

# Directives whose first string is a type ("Shape "plymesh""), as opposed to a name chosen by the
# scene's author ("MakeNamedMaterial "wood""): only a type says which feature is refused.
TYPED_DIRECTIVES = {
    "Shape", "Camera", "Film", "Sampler", "Integrator", "LightSource", "AreaLightSource",
    "Material", "PixelFilter", "Accelerator", "ColorSpace",
}

# Parameters whose string value names a file the scene reads. Film "filename" is the output image,
# so it is left out below.
FILE_PARAMETERS = {"filename", "normalmap", "lensfile"}

# Refusals that differ only in a name the scene chose are one missing feature: building it
# unblocks them all, so they are counted together. (pattern, the family's description)
REFUSAL_FAMILIES = [
    (re.compile(r'parameter "[^"]+" is given more than once'),
     "a parameter given more than once in one directive"),
    (re.compile(r'^Film "[^"]+": the sensor "[^"]+" is not supported'),
     'Film: a "sensor" other than cie1931'),
]

ERROR_RE = re.compile(
    r'^(?P<file>[^\s:][^:]*):(?P<line>\d+):(?P<col>\d+)(?: \((?P<directive>[^)]*)\))?: (?P<msg>.*)$')
# Alphorn's messages for a file that is not there. Only these make "missing files": a file that
# exists but cannot be read is Alphorn's verdict on it, not a gap of the copy.
MISSING_PATTERNS = [
    # An Include, an Import or a spectrum file that cannot be opened.
    re.compile(r'(?P<path>[^\s":]+): cannot open the scene file: No such file or directory'),
    # A mesh, texture or other file parameter checked before the scene is built.
    re.compile(r'cannot open "(?P<path>[^"]+)" \([^)]*\): No such file or directory'),
    re.compile(r'(?P<path>\S+): cannot open: the file does not exist'),
    re.compile(r'the (?:texture file|environment map) "(?P<path>[^"]+)" does not exist'),
]
MEMORY_RE = re.compile(r'need more memory than allowed')


def fail(message):
    print("pbrt-corpus-table.py: " + message, file=sys.stderr)
    sys.exit(2)


# ---------------------------------------------------------------------------------------------
# Reading .pbrt text, only as far as needed to tell scenes from parts and to list file references.

TOKEN_RE = re.compile(r'"[^"]*"|#[^\n]*|\[|\]|[^\s"\[\]#]+')


def tokens(text):
    """The tokens of a pbrt file with their line numbers; comments are dropped."""
    line = 1
    pos = 0
    for m in TOKEN_RE.finditer(text):
        line += text.count("\n", pos, m.start())
        pos = m.start()
        t = m.group(0)
        if not t.startswith("#"):
            yield t, line


def read_text(path):
    try:
        return path.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return None


def is_scene(text):
    return any(t == "WorldBegin" for t, _ in tokens(text))


def references(text):
    """(kind, path) for every file the text names: Include/Import targets and file parameters."""
    refs = []
    directive = None
    toks = list(tokens(text))
    i = 0
    while i < len(toks):
        t = toks[i][0]
        if re.fullmatch(r"[A-Z][A-Za-z]+", t):
            directive = t
            if t in ("Include", "Import") and i + 1 < len(toks) and toks[i + 1][0].startswith('"'):
                refs.append((t, toks[i + 1][0].strip('"')))
        elif t.startswith('"') and " " in t.strip('"'):
            ptype, _, pname = t.strip('"').partition(" ")
            values = []
            j = i + 1
            if j < len(toks) and toks[j][0] == "[":
                j += 1
                while j < len(toks) and toks[j][0] != "]":
                    values.append(toks[j][0])
                    j += 1
            elif j < len(toks):
                values.append(toks[j][0])
            strings = [v.strip('"') for v in values if v.startswith('"')]
            if ptype == "string" and pname in FILE_PARAMETERS and directive != "Film":
                refs.extend(("file", s) for s in strings)
            elif ptype == "spectrum":
                # A string spectrum is either a built-in name ("metal-Au-eta") or a file.
                refs.extend(("spectrum file", s) for s in strings if "." in s)
        i += 1
    return refs


def scan_references(scene_path, corpus_dir):
    """Files the scene and the included files present name, resolved as pbrt-v4 does: relative
    to the folder of the scene file, also inside included files. Returns (absent, included)."""
    base = scene_path.parent
    absent = []
    included = set()
    seen = set()
    todo = [scene_path]
    while todo:
        path = todo.pop(0)
        if path in seen:
            continue
        seen.add(path)
        text = read_text(path)
        if text is None:
            continue
        for kind, ref in references(text):
            target = (base / ref).resolve()
            if kind in ("Include", "Import"):
                included.add(target)
            if target.exists():
                if kind in ("Include", "Import") and target.suffix == ".pbrt":
                    todo.append(target)
            else:
                rel = relative(target, corpus_dir)
                if rel not in absent:
                    absent.append(rel)
    return absent, included


def relative(path, corpus_dir):
    try:
        return path.resolve().relative_to(corpus_dir).as_posix()
    except ValueError:
        return path.as_posix()


# ---------------------------------------------------------------------------------------------
# Running Alphorn and reading its verdict.

def directive_at(path, line):
    """The directive a (possibly continued) line belongs to, for errors that name only a
    parameter: 'Camera "perspective"', or 'MakeNamedMaterial' where the string is a name."""
    text = read_text(path)
    if text is None:
        return None
    last = None
    for i, (t, l) in enumerate(toks := list(tokens(text))):
        if l > line:
            break
        if re.fullmatch(r"[A-Z][A-Za-z]+", t):
            last = t
            if t in TYPED_DIRECTIVES and i + 1 < len(toks) and toks[i + 1][0].startswith('"'):
                last = t + " " + toks[i + 1][0]
    return last


def shorten(msg):
    # Pointers into this repository's documentation belong in Alphorn's message, not in a table.
    msg = re.sub(r"\s*\([^()]*docs/[^()]*\)", "", msg)
    return msg.strip()


def run_scene(scene, corpus_dir, args, tmp):
    """Renders one scene; returns (outcome, detail, warnings, refusal reason or None)."""
    cwd = scene.parent
    # Alphorn runs in the scene's folder and is given the file's name, so the paths in its
    # messages are relative to the scene folder, like the paths inside pbrt-v4 scene files.
    cmd = [args.alphorn, "render", scene.name, "--size", "8x8", "--spp", "1",
           "--threads", str(args.threads), "-o", os.path.join(tmp, "out.exr")]
    if args.max_memory:
        cmd += ["--max-memory", args.max_memory]
    try:
        proc = subprocess.run(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True, errors="replace", timeout=args.timeout)
    except subprocess.TimeoutExpired:
        return "timed out", "no result after %d s" % args.timeout, [], None
    finally:
        for f in ("out.exr", "out.png"):
            try:
                os.remove(os.path.join(tmp, f))
            except OSError:
                pass

    def clean(s):
        for p, r in ((str(cwd) + "/", ""), (str(corpus_dir) + "/", ""), (tmp + "/", "")):
            s = s.replace(p, r)
        return s

    warnings = collections.Counter()
    error = None
    for line in (proc.stdout + proc.stderr).splitlines():
        line = clean(line)
        if line.startswith("warning: "):
            m = ERROR_RE.match(line[len("warning: "):])
            w = m.group("msg") if m else line[len("warning: "):]
            if m and m.group("directive"):
                w = m.group("directive") + ": " + w
            warnings[shorten(w)] += 1
        elif line.startswith("error: ") and error is None:
            error = line[len("error: "):]
    warns = ["%s (%d times)" % (w, n) if n > 1 else w for w, n in sorted(warnings.items())]

    if proc.returncode == 0:
        return "renders", "", warns, None
    if proc.returncode < 0:
        return "crashed", "killed by signal %d" % -proc.returncode, warns, None
    if error is None:
        tail = clean(proc.stderr.strip().splitlines()[-1]) if proc.stderr.strip() else ""
        return "refused", "exit %d without an error line: %s" % (proc.returncode, tail), warns, \
            "exit %d without an error line" % proc.returncode

    m = ERROR_RE.match(error)
    msg = m.group("msg") if m else error
    where = ""
    directive = None
    if m:
        err_file = (cwd / m.group("file")).resolve()
        where = "%s:%s" % (relative(err_file, corpus_dir), m.group("line"))
        directive = m.group("directive")
        if directive is None and not re.match(r'[A-Z][A-Za-z]+( "[^"]*")?: ', msg):
            directive = directive_at(err_file, int(m.group("line")))
    for pat in MISSING_PATTERNS:
        mm = pat.search(msg)
        if mm:
            missing = relative((cwd / mm.group("path")).resolve(), corpus_dir)
            return "missing files", missing, warns, None
    reason = shorten(msg)
    if directive:
        reason = directive + ": " + reason
    if MEMORY_RE.search(msg):
        return "over the memory limit", reason + (" (at %s)" % where if where else ""), warns, None
    return "refused", reason + (" (at %s)" % where if where else ""), warns, reason


def refusal_family(reason):
    for pat, family in REFUSAL_FAMILIES:
        if pat.search(reason):
            return family
    return reason


# ---------------------------------------------------------------------------------------------
# The corpus commit(s) and the document.

def corpus_commits(corpus_dir):
    """A description of the commit(s) the files were read at, and whether the copy is a clone."""
    try:
        top = subprocess.run(["git", "-C", str(corpus_dir), "rev-parse", "--show-toplevel"],
                             capture_output=True, text=True)
        if top.returncode == 0 and pathlib.Path(top.stdout.strip()).resolve() == corpus_dir:
            head = subprocess.run(["git", "-C", str(corpus_dir), "rev-parse", "HEAD"],
                                  capture_output=True, text=True, check=True).stdout.strip()
            return "commit `%s` (a git clone)" % head, True
    except (OSError, subprocess.CalledProcessError):
        pass
    marker = corpus_dir / ".pbrt-v4-scenes-commit"
    if marker.is_file():
        return "commit `%s` (recorded by tools/fetch-pbrt-v4-scenes.sh)" % \
            marker.read_text().strip(), True
    manifest = corpus_dir / "MANIFEST.txt"
    if manifest.is_file():
        # A partial copy's MANIFEST.txt lists each written file as "path size commit ...".
        counts = collections.Counter()
        for line in manifest.read_text(errors="replace").splitlines():
            f = line.split()
            if len(f) >= 3 and f[0].endswith(".pbrt") and re.fullmatch(r"[0-9a-f]{40}", f[2]):
                counts[f[2]] += 1
        if counts:
            parts = ", ".join("`%s` (%d)" % (c[:12], n) for c, n in
                              sorted(counts.items(), key=lambda x: (-x[1], x[0])))
            return ("%d commits, one per file as the copy records it (commit, number of files): "
                    "%s" % (len(counts), parts)), False
    return "an unknown commit (not a git clone, and no record of one)", False


def md(s):
    return s.replace("|", "\\|").replace("\n", " ")


def code_list(items, limit):
    shown = ", ".join("`%s`" % md(i) for i in items[:limit])
    if len(items) > limit:
        shown += " and %d more" % (len(items) - limit)
    return shown


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("corpus_dir", metavar="CORPUS_DIR")
    ap.add_argument("--alphorn", help="the alphorn program (default: build/cli/alphorn of this "
                    "repository, else alphorn on the PATH)")
    ap.add_argument("--out", help="the Markdown file to write (default: docs/pbrt-v4-corpus.md)")
    ap.add_argument("--listing", help="the repository's .pbrt paths, one per line")
    ap.add_argument("--timeout", type=int, default=300, help="seconds per scene (default 300)")
    ap.add_argument("--max-memory", default="8GB",
                    help="Alphorn's --max-memory per scene (default 8GB; '' for none)")
    ap.add_argument("--threads", type=int, default=1,
                    help="render threads (default 1: the scenes are built, hardly rendered)")
    args = ap.parse_args()
    argv = sys.argv[:]

    corpus_dir = pathlib.Path(args.corpus_dir)
    if not corpus_dir.is_dir():
        fail("CORPUS_DIR %s is not a directory (make one with tools/fetch-pbrt-v4-scenes.sh)"
             % args.corpus_dir)
    corpus_dir = corpus_dir.resolve()
    if args.alphorn is None:
        built = REPO_ROOT / "build" / "cli" / "alphorn"
        args.alphorn = str(built) if built.is_file() else shutil.which("alphorn")
        if args.alphorn is None:
            fail("no alphorn found (build it, or give --alphorn PATH)")
    try:
        version = subprocess.run([args.alphorn, "--version"], capture_output=True, text=True,
                                 timeout=60).stdout.strip()
    except OSError as e:
        fail("cannot run %s: %s" % (args.alphorn, e))
    if not version:
        fail("%s --version printed nothing; is it Alphorn?" % args.alphorn)
    args.alphorn = os.path.abspath(args.alphorn) if os.sep in args.alphorn else args.alphorn

    present = sorted(p for p in corpus_dir.rglob("*.pbrt") if p.is_file() and ".git" not in p.parts)
    texts = {p: read_text(p) for p in present}
    scenes = [p for p in present if texts[p] is not None and is_scene(texts[p])]
    if not scenes:
        fail("CORPUS_DIR %s holds no scene file (no .pbrt file with WorldBegin); is it the "
             "pbrt-v4-scenes corpus?" % corpus_dir)
    listed = []
    if args.listing:
        try:
            listed = [l.strip() for l in open(args.listing, encoding="utf-8")
                      if l.strip() and not l.startswith("#")]
        except OSError as e:
            fail("cannot read --listing %s: %s" % (args.listing, e))
    present_rel = {relative(p, corpus_dir) for p in present}
    absent_listed = sorted(set(listed) - present_rel)

    rows = {}  # path -> (Alphorn column, why column, warnings column)
    outcomes = collections.Counter()
    refusals = collections.defaultdict(list)  # family -> [(scene, detailed reason)]
    included_by = collections.defaultdict(set)
    all_absent = set()
    with tempfile.TemporaryDirectory(prefix="pbrt-corpus-table-") as tmp:
        for n, scene in enumerate(scenes, 1):
            rel = relative(scene, corpus_dir)
            print("[%d/%d] %s" % (n, len(scenes), rel), file=sys.stderr, flush=True)
            outcome, detail, warns, reason = run_scene(scene, corpus_dir, args, tmp)
            absent, included = scan_references(scene, corpus_dir)
            all_absent.update(absent)
            for inc in included:
                included_by[relative(inc, corpus_dir)].add(rel)
            outcomes[outcome] += 1
            if outcome == "missing files":
                why = "Alphorn stopped at `%s`" % md(detail)
                others = [a for a in absent if a != detail]
                if others:
                    why += "; also absent here: " + code_list(others, 4)
            elif outcome == "refused":
                why = md(detail)
                refusals[refusal_family(reason)].append((rel, reason))
            else:
                why = md(detail)
            rows[rel] = ("**%s**" % outcome, why,
                         "; ".join(md(w) for w in warns))
    for p in present:
        rel = relative(p, corpus_dir)
        if rel not in rows:
            users = sorted(included_by.get(rel, ()))
            note = ("included by " + code_list(users, 3)) if users else \
                "included by no scene file of this copy"
            rows[rel] = ("included part", note, "")
    for rel in absent_listed:
        users = sorted(included_by.get(rel, ()))
        note = ("an included part (included by %s)" % code_list(users, 3)) if users else \
            "not read, and no file of this copy includes it: scene or part is not known here"
        rows[rel] = ("not in this copy", note, "")
    # Included .pbrt files that are absent and that the listing lacks too: the scenes name them,
    # so the repository has them, and a reader looking for them should find a row.
    unlisted = sorted(rel for rel in included_by if rel not in rows and
                      rel.endswith(".pbrt") and not (corpus_dir / rel).exists())
    for rel in unlisted:
        note = "an included part (included by %s)" % code_list(sorted(included_by[rel]), 3)
        if listed:
            note += "; not in the listing either"
        rows[rel] = ("not in this copy", note, "")

    commits, is_clone = corpus_commits(corpus_dir)
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    command = " ".join(shlex.quote(a) for a in ["tools/pbrt-corpus-table.py"] + argv[1:])
    n_parts = sum(1 for r in rows.values() if r[0] == "included part")
    partial = not is_clone and (bool(absent_listed) or outcomes["missing files"] > 0)

    out = []
    out.append("# Alphorn on the pbrt-v4 scene corpus")
    out.append("")
    out.append("<!-- Generated by tools/pbrt-corpus-table.py; edit the script, not this file. -->")
    out.append("")
    intro = (
        "What Alphorn does with each file of the public pbrt-v4 test scenes "
        "([mmp/pbrt-v4-scenes](https://github.com/mmp/pbrt-v4-scenes), see "
        "[pbrt-v4-scenes.md](pbrt-v4-scenes.md)). A scene file (one with `WorldBegin`) is "
        "rendered at 8x8 pixels and 1 sample per pixel, which reads and builds the whole scene "
        "but renders almost nothing: it **renders** (exit 0), is **refused** (Alphorn's first "
        "error names a feature or value it does not render), or stops at **missing files** (a "
        "file the scene names is not in the copy). Alphorn stops at its first error, so a scene "
        "may need more than the one thing shown. The other `.pbrt` files are parts the scenes "
        "include.")
    out.append(intro)
    out.append("")
    if partial:
        def kind(path):
            sfx = pathlib.PurePosixPath(path).suffixes
            # A compressed file is named by what it holds: .ply.gz, .pbrt.gz.
            return "".join(sfx[-2:]) if sfx[-1:] == [".gz"] else "".join(sfx[-1:])
        by_kind = collections.Counter(kind(a) for a in all_absent)
        kinds = ", ".join("%d `%s`" % (n, k or "(no extension)")
                          for k, n in sorted(by_kind.items(), key=lambda x: (-x[1], x[0])))
        out.append(
            "This table was made on a **partial copy** of the corpus (not a git clone): %d files "
            "the scene files here name, directly or through included files, are absent from it "
            "(%s). So most scenes show missing files here; that is a fact of this copy, not of "
            "Alphorn, and it hides whatever Alphorn would refuse further on in those scenes."
            % (len(all_absent), kinds))
        out.append("")
    out.append(
        "To regenerate it on a full clone: `tools/fetch-pbrt-v4-scenes.sh` (a shallow clone into "
        "`../pbrt-v4-scenes`), then `tools/pbrt-corpus-table.py ../pbrt-v4-scenes` after "
        "building Alphorn (`--alphorn PATH` for another build).")
    out.append("")
    out.append("- Corpus: %s." % commits)
    out.append("- Made: %s, with `%s`." % (now, md(version)))
    out.append("- Command: `%s`" % md(command))
    out.append("")
    out.append("## Summary")
    out.append("")
    out.append("%d scene files in this copy:" % len(scenes))
    out.append("")
    for outcome in ("renders", "refused", "missing files", "over the memory limit",
                    "timed out", "crashed"):
        if outcomes[outcome] or outcome in ("renders", "refused", "missing files"):
            out.append("- %s: %d" % (outcome, outcomes[outcome]))
    out.append("")
    extra = "%d included parts in this copy" % n_parts
    if listed:
        extra += ("; %d of the %d `.pbrt` files of the listing of the repository are not in "
                  "this copy" % (len(absent_listed), len(set(listed))))
    if unlisted:
        extra += ("; %d more included `.pbrt` files are absent%s"
                  % (len(unlisted), " and not in the listing" if listed else ""))
    out.append(extra + ".")
    out.append("")
    out.append("### What the refusals ask for")
    out.append("")
    if refusals:
        out.append("Each distinct reason of a refusal, with the number of scenes it stops (most "
                   "first). Only a scene's first error counts%s." % (
                       "; the %d scenes that stop at a missing file are not counted, since "
                       "Alphorn did not reach the rest of them" % outcomes["missing files"]
                       if outcomes["missing files"] else ""))
        out.append("")
        for family, items in sorted(refusals.items(), key=lambda kv: (-len(kv[1]), kv[0])):
            scenes_list = ", ".join("`%s`" % s for s, _ in items)
            line = "- %s → %d scene%s: %s" % (md(family), len(items),
                                               "" if len(items) == 1 else "s", scenes_list)
            details = sorted({r for _, r in items if r != family})
            if details:
                line += " (" + "; ".join(md(d) for d in details) + ")"
            out.append(line)
    else:
        out.append("No scene was refused.")
    out.append("")
    out.append("## The files")
    out.append("")
    out.append("| scene file | Alphorn | why / what is missing | warnings |")
    out.append("|---|---|---|---|")
    for rel in sorted(rows):
        a, why, warns = rows[rel]
        out.append("| `%s` | %s | %s | %s |" % (md(rel), a, why, warns))
    out.append("")

    out_path = pathlib.Path(args.out) if args.out else REPO_ROOT / "docs" / "pbrt-v4-corpus.md"
    out_path.parent.mkdir(parents=True, exist_ok=True)
    out_path.write_text("\n".join(out), encoding="utf-8")
    print("wrote %s: %s" % (out_path, ", ".join("%s %d" % kv for kv in sorted(outcomes.items()))),
          file=sys.stderr)


if __name__ == "__main__":
    main()
