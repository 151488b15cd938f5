#!/usr/bin/env bash
# Brings the public pbrt-v4 test scenes (github.com/mmp/pbrt-v4-scenes, about 1.5 GB of scene
# files, PLY meshes and textures) to a directory OUTSIDE this repository: no scene data is ever
# committed here. See docs/pbrt-v4-scenes.md.
#
#   tools/fetch-pbrt-v4-scenes.sh [--commit SHA] [--from DIR [--link]] [DEST]
#
# DEST defaults to ../pbrt-v4-scenes beside the checkout. Without --from it makes a shallow clone
# (one commit, no history) of the scenes repository; the repository keeps its meshes and textures
# as ordinary git blobs (it has no .gitattributes, so no Git LFS is involved). --commit pins the
# clone to SHA (any commit of the repository); without it the tip of the default branch is taken.
# Either way the commit is printed and written to DEST/.pbrt-v4-scenes-commit.
# --from DIR copies an existing local copy (a clone, or a partial copy of its files) instead;
# with --link it makes DEST a symbolic link to DIR. Idempotent: a DEST that is already a clone at
# the wanted commit is left alone, and a clone at another commit is moved to it.
set -euo pipefail
url=https://github.com/mmp/pbrt-v4-scenes
repo_root=$(cd "$(dirname "$0")/.." && pwd)
commit="" from="" link=0 dest=""
usage() { sed -n '2,16p' "$0" | sed 's/^# \{0,1\}//'; }
while [ $# -gt 0 ]; do
  case "$1" in
    --commit) commit=${2:?--commit needs a SHA}; shift 2 ;;
    --from) from=${2:?--from needs a directory}; shift 2 ;;
    --link) link=1; shift ;;
    -h|--help) usage; exit 0 ;;
    -*) echo "fetch-pbrt-v4-scenes.sh: unknown option $1" >&2; usage >&2; exit 2 ;;
    *) [ -z "$dest" ] || { echo "fetch-pbrt-v4-scenes.sh: one DEST only" >&2; exit 2; }
       dest=$1; shift ;;
  esac
done
dest=${dest:-$repo_root/../pbrt-v4-scenes}
if [ -n "$commit" ] && ! [[ "$commit" =~ ^[0-9a-fA-F]{7,40}$ ]]; then
  echo "fetch-pbrt-v4-scenes.sh: --commit takes a hexadecimal commit id, not '$commit'" >&2
  exit 2
fi
[ "$link" -eq 0 ] || [ -n "$from" ] || { echo "fetch-pbrt-v4-scenes.sh: --link needs --from" >&2; exit 2; }

# Refuse a destination inside the repository: scene data must never be committed here. The path
# is resolved through its nearest existing ancestor, so symbolic links cannot hide it.
abs_path() {
  local p=$1 tail=""
  while [ ! -e "$p" ]; do tail=/$(basename "$p")$tail; p=$(dirname "$p"); done
  echo "$(cd "$p" && pwd -P)$tail"
}
dest_abs=$(abs_path "$dest")
root_abs=$(cd "$repo_root" && pwd -P)
case "$dest_abs/" in
  "$root_abs"/*) echo "fetch-pbrt-v4-scenes.sh: refusing $dest_abs: it is inside the repository" \
    "($root_abs); choose a directory outside it, e.g. $root_abs/../pbrt-v4-scenes" >&2; exit 1 ;;
esac

if [ -n "$from" ]; then
  [ -d "$from" ] || { echo "fetch-pbrt-v4-scenes.sh: --from $from is not a directory" >&2; exit 1; }
  from_abs=$(cd "$from" && pwd -P)
  if [ "$from_abs" = "$dest_abs" ]; then echo "$dest_abs is already the corpus"; exit 0; fi
  case "$from_abs/" in
    "$root_abs"/*) echo "fetch-pbrt-v4-scenes.sh: refusing --from inside the repository" >&2; exit 1 ;;
  esac
  if [ "$link" -eq 1 ]; then
    if [ -L "$dest_abs" ] && [ "$(readlink "$dest_abs")" = "$from_abs" ]; then
      echo "$dest_abs already links to $from_abs"
    else
      [ ! -e "$dest_abs" ] || { echo "fetch-pbrt-v4-scenes.sh: $dest_abs exists; remove it first" >&2; exit 1; }
      echo "linking $dest_abs -> $from_abs"
      mkdir -p "$(dirname "$dest_abs")"
      ln -s "$from_abs" "$dest_abs"
    fi
  else
    echo "copying $from_abs -> $dest_abs (files already there and unchanged are kept)"
    mkdir -p "$dest_abs"
    cp -a -u "$from_abs/." "$dest_abs/"
  fi
  if git -C "$dest_abs" rev-parse -q --verify HEAD >/dev/null 2>&1; then
    have=$(git -C "$dest_abs" rev-parse HEAD)
    echo "$have" >"$dest_abs/.pbrt-v4-scenes-commit"
    echo "pbrt-v4-scenes at commit $have in $dest_abs"
  else
    echo "pbrt-v4-scenes in $dest_abs (not a git clone: its commit is not known here)"
  fi
  exit 0
fi

command -v git >/dev/null || { echo "fetch-pbrt-v4-scenes.sh: git is needed (apt-get install git)" >&2; exit 1; }
if [ -e "$dest_abs" ] && [ ! -d "$dest_abs/.git" ]; then
  if [ -n "$(ls -A "$dest_abs" 2>/dev/null)" ]; then
    echo "fetch-pbrt-v4-scenes.sh: $dest_abs exists and is not a git clone; use --from, or remove it" >&2
    exit 1
  fi
fi
if [ ! -d "$dest_abs/.git" ]; then
  echo "creating a shallow clone of $url in $dest_abs"
  mkdir -p "$dest_abs"
  git -C "$dest_abs" init -q
  git -C "$dest_abs" remote add origin "$url"
fi
want=${commit:-HEAD}
if [ -n "$commit" ] && git -C "$dest_abs" cat-file -e "$commit^{commit}" 2>/dev/null &&
  [ "$(git -C "$dest_abs" rev-parse HEAD 2>/dev/null)" = "$(git -C "$dest_abs" rev-parse "$commit^{commit}")" ]; then
  echo "already at $commit"
else
  echo "fetching $want (depth 1; about 1.5 GB the first time)"
  git -C "$dest_abs" fetch --depth 1 origin "$want"
  git -C "$dest_abs" checkout -q --detach FETCH_HEAD
fi
have=$(git -C "$dest_abs" rev-parse HEAD)
echo "$have" >"$dest_abs/.pbrt-v4-scenes-commit"
echo "pbrt-v4-scenes at commit $have in $dest_abs"
