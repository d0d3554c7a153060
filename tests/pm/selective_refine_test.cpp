#include "pm/selective_refine.hpp"
#include <gtest/gtest.h>
