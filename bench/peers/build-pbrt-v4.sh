#!/usr/bin/env bash
# Builds pbrt-v4 (CPU only, Release) from source for the peer bench, into a directory outside the
# repository: pbrt-v4's sources and binary are fetched data, never part of Alphorn.
#
#   build-pbrt-v4.sh [--sources DIR | --mirror DIR] [DEST]
#
# Without options it clones github.com/mmp/pbrt-v4 and its submodules at the pinned commits below
# into DEST/src. --sources DIR builds a ready source tree (with its src/ext submodules filled in);
# --mirror DIR clones from local bare repositories named DIR/OWNER+NAME/repo instead of GitHub
# (a submodule whose pinned commit the mirror lacks is checked out at the mirror's HEAD, with a
# warning). DEST defaults to ../peers/pbrt-v4 beside the checkout (outside the repository; one
# inside it is refused); the binary is DEST/bin/pbrt.
# Idempotent: an existing DEST/src and DEST/build are reused.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
pbrt_commit=5f7a606806a4ac7b939131ded9d7a30ebd02416e
# path  owner/name  pinned commit (the gitlinks of pbrt-v4 at $pbrt_commit)
submodules=(
  "src/ext/double-conversion mmp/double-conversion 101e1ba89dc41ceb75090831da97c43a76cd2906"
  "src/ext/filesystem wjakob/filesystem c5f9de30142453eb3c6fe991e82dfc2583373116"
  "src/ext/glfw glfw/glfw 7b6aead9fb88b3623e3b3725ebb42670cbe4c579"
  "src/ext/libdeflate mmp/libdeflate 1fd0bea6ca2073c68493632dafc4b1ddda1bcbc3"
  "src/ext/lodepng lvandeve/lodepng 8c6a9e30576f07bf470ad6f09458a2dcd7a6a84a"
  "src/ext/openexr AcademySoftwareFoundation/openexr f723c3940fff287c0a26b425b90a8e764823bfd4"
  "src/ext/openvdb AcademySoftwareFoundation/openvdb 414bed84c2fc22e188eac7b611aa85c7edd7a5a9"
  "src/ext/ptex wdas/ptex 054047d02b9e06e690420b407114d2872435b953"
  "src/ext/qoi phoboslab/qoi 028c75fd26e5e0758c7c711216c00404994c1ad3"
  "src/ext/stb nothings/stb af1a5bc352164740c1cc1354942b1c6b72eacb8a"
  "src/ext/utf8proc JuliaStrings/utf8proc d7bf128df773c2a1a7242eb80e51e91a769fc985"
  "src/ext/zlib madler/zlib 5a82f71ed1dfc0bec044d9702463dbdf84ea3b71"
)
sources="" mirror="" dest=""
while [ $# -gt 0 ]; do
  case "$1" in
    --sources) sources=${2:?--sources needs a directory}; shift 2 ;;
    --mirror) mirror=${2:?--mirror needs a directory}; shift 2 ;;
    -h|--help) sed -n '2,14p' "$0"; exit 0 ;;
    -*) echo "build-pbrt-v4.sh: unknown option $1" >&2; exit 2 ;;
    *) dest=$1; shift ;;
  esac
done
repository=$(cd "$here/../.." && pwd)
dest=${dest:-$repository/../peers/pbrt-v4}
mkdir -p "$dest"
dest=$(cd "$dest" && pwd -P)
case "$dest/" in
  "$(cd "$repository" && pwd -P)"/*)
    echo "build-pbrt-v4.sh: $dest lies inside the repository; build pbrt-v4 outside it" >&2
    exit 2 ;;
esac

# Debian packages: compilers and tools, zlib and OpenEXR (used instead of the bundled copies),
# OpenGL and the X11 headers GLFW's X11 backend needs (pbrt links GLFW for its interactive viewer).
apt_packages=(g++ cmake ninja-build git pkg-config zlib1g-dev libopenexr-dev libimath-dev libgl-dev
  libx11-dev libxrandr-dev libxinerama-dev libxcursor-dev libxi-dev libxext-dev)
missing=()
for p in "${apt_packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing Debian packages: ${missing[*]}"
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

url_of() { # owner/name -> clone URL
  if [ -n "$mirror" ]; then echo "$mirror/${1/\//+}/repo"; else echo "https://github.com/$1"; fi
}
checkout_at() { # dir owner/name commit
  local dir=$1 repo=$2 commit=$3 url
  url=$(url_of "$repo")
  if [ -n "$mirror" ]; then
    # A local snapshot can lack large blobs anywhere in its history, so nothing is fetched from it:
    # the new repository borrows its objects (alternates) and checks out what is there.
    [ -d "$url" ] || { echo "build-pbrt-v4.sh: no mirror $url" >&2; exit 1; }
    [ -d "$dir/.git" ] || { rm -rf "$dir"; mkdir -p "$dir"; git -C "$dir" init -q; }
    echo "$url/objects" >"$dir/.git/objects/info/alternates"
    if ! git -C "$dir" cat-file -e "$commit^{commit}" 2>/dev/null; then
      local head
      head=$(git --git-dir="$url" rev-parse HEAD)
      echo "WARNING: $url lacks the pinned commit $commit; using its HEAD $head instead" >&2
      commit=$head
    fi
    if [ "$(git -C "$dir" rev-parse -q --verify HEAD || true)" != "$commit" ]; then
      git -C "$dir" read-tree "$commit"
      git -C "$dir" checkout-index -a -f 2>/dev/null ||
        echo "WARNING: $repo at $commit: some files are absent from the mirror (listed below)" >&2
      git -C "$dir" update-ref --no-deref HEAD "$commit"
      git -C "$dir" ls-files --deleted | sed 's/^/    absent: /' >&2
    fi
    return
  fi
  if [ ! -d "$dir/.git" ]; then
    rm -rf "$dir"; mkdir -p "$dir"
    git -C "$dir" init -q
    git -C "$dir" remote add origin "$url"
  fi
  git -C "$dir" cat-file -e "$commit^{commit}" 2>/dev/null || git -C "$dir" fetch -q --depth 1 origin "$commit"
  git -C "$dir" checkout -q --detach "$commit"
}

if [ -z "$sources" ]; then
  sources=$dest/src
  echo "pbrt-v4 $pbrt_commit -> $sources"
  checkout_at "$sources" mmp/pbrt-v4 "$pbrt_commit"
  for s in "${submodules[@]}"; do
    read -r path repo commit <<<"$s"
    echo "  $path: $repo $commit"
    checkout_at "$sources/$path" "$repo" "$commit"
  done
fi
sources=$(cd "$sources" && pwd)
[ -f "$sources/src/pbrt/cmd/pbrt.cpp" ] || { echo "build-pbrt-v4.sh: $sources is no pbrt-v4 tree" >&2; exit 1; }

# Two generated data tables of pbrt-v4 are over the size a local snapshot keeps. Without them pbrt
# does not link; they are replaced by tables generated here (gen-pbrt-v4-tables.py beside this
# script): a digitally shifted (0,2)-sequence for the pmj02bn sampler's points and stratified
# white noise for the blue-noise textures. Only the pmj02bn sampler and 8-bit image dithering read
# them; the default zsobol sampler and EXR output do not.
for t in bluenoise pmj02tables; do
  if [ ! -s "$sources/src/pbrt/util/$t.cpp" ]; then
    echo "NOTE: src/pbrt/util/$t.cpp is absent: writing a substitute (see gen-pbrt-v4-tables.py)" >&2
    python3 "$here/gen-pbrt-v4-tables.py" "$t" "$sources/src/pbrt/util/$t.cpp"
  fi
done

# pbrt's CMake refuses a submodule whose HEAD is not the pinned commit. When one is not (the
# mirror lacked it), that check is switched off by hiding git from CMake, and said so here.
cmake_extra=()
for s in "${submodules[@]}"; do
  read -r path repo commit <<<"$s"
  [ -d "$sources/$path" ] || { echo "build-pbrt-v4.sh: submodule $path is missing in $sources" >&2; exit 1; }
  have=$(git -C "$sources/$path" rev-parse HEAD 2>/dev/null || echo none)
  if [ "$have" != "$commit" ]; then
    echo "NOTE: $path is at $have, not the pinned $commit: pbrt's submodule check is disabled" >&2
    cmake_extra=(-DCMAKE_DISABLE_FIND_PACKAGE_Git=ON)
  fi
done

# Release, CPU only (no CUDA/OptiX is looked for when PBRT_OPTIX_PATH is empty), GLFW without
# Wayland (no Wayland headers needed). zlib and OpenEXR come from Debian: pbrt's CMake uses them
# when find_package finds them. Still bundled, as pbrt's CMake has no switch for them: libdeflate,
# double-conversion, Ptex, utf8proc, GLFW/glad, FLIP, and the header-only stb, lodepng, qoi,
# filesystem and NanoVDB.
cmake -S "$sources" -B "$dest/build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DPBRT_OPTIX_PATH= \
  -DGLFW_BUILD_WAYLAND=OFF -DBUILD_TESTING=OFF "${cmake_extra[@]}"
nice -n 19 cmake --build "$dest/build" -j 2 --target pbrt_exe
mkdir -p "$dest/bin"
cp "$dest/build/pbrt" "$dest/bin/pbrt"
echo "pbrt-v4: $dest/bin/pbrt"
