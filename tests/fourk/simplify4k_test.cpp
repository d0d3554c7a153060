#include "fourk/simplify4k.hpp"
#include <gtest/gtest.h>
