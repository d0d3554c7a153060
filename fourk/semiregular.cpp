#include "fourk/semiregular.hpp"
