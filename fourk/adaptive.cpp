#include "fourk/adaptive.hpp"
