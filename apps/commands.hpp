#pragma once
/// The `varmesh` command line: subcommands info, terrain, render, demo. run() parses argv, runs the
/// subcommand, prints a one-line message on any error and returns the process exit status.
namespace varmesh::app {

int run(int argc, char** argv);

}  // namespace varmesh::app
