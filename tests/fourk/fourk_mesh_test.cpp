#include "fourk/fourk_mesh.hpp"
#include <gtest/gtest.h>
