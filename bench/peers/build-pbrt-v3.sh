#!/usr/bin/env bash
# Builds pbrt-v3 (https://github.com/mmp/pbrt-v3) against Debian 12's packages, for the peer
# comparison only: pbrt is not a Debian package and no test depends on it.
#
#   bench/peers/build-pbrt-v3.sh PBRT_V3_SOURCE_DIR [OUTPUT_BINARY]
#
# PBRT_V3_SOURCE_DIR is a checkout of pbrt-v3 (its git submodules are not needed: glog, OpenEXR
# and zlib come from Debian; Ptex textures, which no scene here uses and Debian 12 does not
# package, are left out). The source tree is copied, never modified. Takes ~10 minutes on 2 cores.
set -euo pipefail
src=${1:?usage: build-pbrt-v3.sh PBRT_V3_SOURCE_DIR [OUTPUT_BINARY]}
out=${2:-$PWD/pbrt-v3/pbrt}
apt_packages=(libgoogle-glog-dev libopenexr-dev zlib1g-dev g++ make)
missing=()
for p in "${apt_packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cp -r "$src/src" "$work/src"
# Without Ptex: drop its texture from the scene-description API.
sed -i -e '/#include "textures\/ptex.h"/d' \
       -e 's/else if (name == "ptex")/else if (false)/' \
       -e 's/tex = CreatePtexFloatTexture(tex2world, tp);/tex = nullptr;/' \
       -e 's/tex = CreatePtexSpectrumTexture(tex2world, tp);/tex = nullptr;/' "$work/src/core/api.cpp"
rm -f "$work/src/textures/ptex.cpp" "$work/src/textures/ptex.h"
sources=$(cd "$work/src" && ls core/*.cpp accelerators/*.cpp cameras/*.cpp filters/*.cpp \
  integrators/*.cpp lights/*.cpp materials/*.cpp media/*.cpp samplers/*.cpp shapes/*.cpp \
  textures/*.cpp ext/lodepng.cpp ext/rply.cpp ext/targa.cpp ext/ArHosekSkyModel.c main/pbrt.cpp)
cat >"$work/Makefile" <<MAKE
CXXFLAGS = -O3 -std=gnu++11 -w -DNDEBUG -DPBRT_CONSTEXPR=constexpr -DPBRT_HAVE_MMAP -DPBRT_HAVE_POSIX_MEMALIGN \
  -DPBRT_THREAD_LOCAL=thread_local -DPBRT_HAVE_ALIGNAS -DPBRT_HAVE_ALIGNOF -DPBRT_HAVE_CONSTEXPR \
  -DPBRT_HAVE_HEX_FP_CONSTANTS -DPBRT_HAVE_BINARY_CONSTANTS -DPBRT_HAVE_ITIMER -DPBRT_NOINLINE='__attribute__((noinline))' \
  -DPBRT_HAVE_ALLOCA_H -DPBRT_HAVE_NONPOD_IN_UNIONS -Isrc -Isrc/core -Isrc/ext -I/usr/include/OpenEXR -I/usr/include/Imath
OBJS = \$(patsubst %.c,obj/%.o,\$(patsubst %.cpp,obj/%.o,$(echo $sources)))
pbrt: \$(OBJS)
	\$(CXX) -o \$@ \$^ -lglog -lOpenEXR -lImath -lIex -lz -lpthread
obj/%.o: src/%.cpp
	@mkdir -p \$(dir \$@)
	\$(CXX) \$(CXXFLAGS) -c \$< -o \$@
obj/%.o: src/%.c
	@mkdir -p \$(dir \$@)
	\$(CXX) \$(CXXFLAGS) -x c++ -c \$< -o \$@
MAKE
make -C "$work" -j "$(nproc)" pbrt
mkdir -p "$(dirname "$out")"
cp "$work/pbrt" "$out"
echo "pbrt-v3: $out"
