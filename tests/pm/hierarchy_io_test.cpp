#include "pm/hierarchy_io.hpp"
#include <gtest/gtest.h>
