#include "fourk/strips.hpp"
