#include "apps/commands.hpp"

namespace varmesh::app {

int run(int, char**) { return 0; }

}  // namespace varmesh::app
