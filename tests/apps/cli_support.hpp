#pragma once
// Running the varmesh executable from the CLI tests: exit status, stdout and stderr of one command.
#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <utility>

namespace varmesh::testing {

struct CmdResult {
  int status;
  std::string out, err;
};

inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Runs `varmesh <args>` with stdout and stderr captured in files of `dir`.
inline CmdResult run_varmesh(const std::string& args, const std::filesystem::path& dir) {
  const std::filesystem::path out = dir / "stdout.txt", err = dir / "stderr.txt";
  const std::string cmd = std::string(VARMESH_EXE) + " " + args + " >" + out.string() + " 2>" + err.string();
  const int raw = std::system(cmd.c_str());
  return {WIFEXITED(raw) ? WEXITSTATUS(raw) : -1, slurp(out), slurp(err)};
}

// Sets an environment variable for the life of the guard (the commands run through std::system inherit
// it), then puts back what was there.
class EnvGuard {
 public:
  EnvGuard(const char* name, const std::string& value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = std::string(old);
    ::setenv(name, value.c_str(), 1);
  }
  EnvGuard(const EnvGuard&) = delete;
  EnvGuard& operator=(const EnvGuard&) = delete;
  ~EnvGuard() {
    if (old_) ::setenv(name_, old_->c_str(), 1);
    else ::unsetenv(name_);
  }

 private:
  const char* name_;
  std::optional<std::string> old_;
};

inline bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

/// The RMS and max (object units) of the line "<what>: distance from the ..." that --measure prints, or NaN
/// when there is no such line.
inline std::pair<double, double> measured_distance(const std::string& out, const std::string& what) {
  const double nan = std::nan("");
  const std::size_t at = out.find(what + ": distance from the ");
  if (at == std::string::npos) return {nan, nan};
  const std::size_t rms = out.find("RMS ", at), max = out.find(", max ", at);
  if (rms == std::string::npos || max == std::string::npos) return {nan, nan};
  return {std::stod(out.substr(rms + 4)), std::stod(out.substr(max + 6))};
}

inline int count_lines(const std::string& s) {
  int n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

}  // namespace varmesh::testing
