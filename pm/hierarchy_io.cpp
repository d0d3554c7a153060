#include "pm/hierarchy_io.hpp"
