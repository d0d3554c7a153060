#include "pm/selective_refine.hpp"
