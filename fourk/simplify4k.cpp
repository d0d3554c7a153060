#include "fourk/simplify4k.hpp"
