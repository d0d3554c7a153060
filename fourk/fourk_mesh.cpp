#include "fourk/fourk_mesh.hpp"
