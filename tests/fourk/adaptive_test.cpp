#include "fourk/adaptive.hpp"
#include <gtest/gtest.h>
