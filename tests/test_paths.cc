// The only place the checkout's and the build's absolute paths are compiled in. Every other test
// object is then the same in any clone of the sources, so that ccache serves a fresh clone (CI's)
// the objects an earlier build left (scripts/build-env.sh keys on checkout-relative paths, but a
// path inside a -D string is part of the key as written).

#include "test_data.h"

namespace mlp::test {

std::string SourceDir() { return MLP_SOURCE_DIR; }

std::string Program(const std::string& name) { return std::string(MLP_PROGRAM_DIR) + "/" + name; }

}  // namespace mlp::test
