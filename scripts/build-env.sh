# Sourced by the build scripts: the compiler cache. ccache keys each object by its preprocessed
# source and flags; CCACHE_BASEDIR turns the checkout's absolute paths into relative ones, so a
# fresh clone elsewhere (CI's) hits the objects an earlier build of the same sources left.
# Without ccache the build is the same, only slower.
mlp_root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
mlp_launcher=()
if command -v ccache >/dev/null; then
  export CCACHE_BASEDIR="$mlp_root"
  export CCACHE_MAXSIZE="${CCACHE_MAXSIZE:-25G}"  # release, sanitized and arm64 objects
  export CCACHE_NOHASHDIR=1                        # no -g paths in the key (sanitized -g1)
  mlp_launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi
