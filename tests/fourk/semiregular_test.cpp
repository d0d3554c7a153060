#include "fourk/semiregular.hpp"
#include <gtest/gtest.h>
