#include "fourk/strips.hpp"
#include <gtest/gtest.h>
