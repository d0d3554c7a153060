#include "apps/commands.hpp"

int main(int argc, char** argv) { return varmesh::app::run(argc, argv); }
