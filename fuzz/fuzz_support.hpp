#pragma once
// Shared by the harnesses: what counts as a finding, and small helpers to patch a fuzzed file image so that
// its checksums and size field agree with its content (otherwise the fuzzer stops at the checksum).
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <new>

#include "multitri/errors.hpp"

namespace varmesh::fuzz {

// A harness found a bug: print why (libFuzzer then saves the input) and abort.
[[noreturn]] inline void finding(const char* what, const char* detail = "") {
  std::fprintf(stderr, "varmesh fuzz finding: %s %s\n", what, detail);
  std::abort();
}

// Checks a property that must hold on every input the library accepted.
#define VARMESH_FUZZ_CHECK(cond) ((cond) ? static_cast<void>(0) : ::varmesh::fuzz::finding("check failed:", #cond))

// Runs fn; the library's documented error types for bad input (IoError, InvalidInput) end the run quietly,
// anything else (std::logic_error: a broken internal invariant, std::bad_alloc on a tiny input, any other
// exception) is a finding. Returns whether fn completed.
template <class Fn>
bool run_expecting_only_documented_errors(Fn&& fn) {
  try {
    fn();
    return true;
  } catch (const IoError&) {
    return false;
  } catch (const InvalidInput&) {
    return false;
  } catch (const std::bad_alloc&) {
    finding("std::bad_alloc on a small input");
  } catch (const std::exception& e) {
    finding("undocumented exception:", e.what());
  } catch (...) {
    finding("non-std exception");
  }
}

// Runs fn on something the library accepted: no exception at all may escape.
template <class Fn>
void run_expecting_no_error(Fn&& fn) {
  try {
    fn();
  } catch (const std::exception& e) {
    finding("exception on accepted input:", e.what());
  } catch (...) {
    finding("non-std exception");
  }
}

inline void put_le(std::uint8_t* at, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) at[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
inline std::uint64_t get_le(const std::uint8_t* at, int bytes) {
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v |= static_cast<std::uint64_t>(at[i]) << (8 * i);
  return v;
}

}  // namespace varmesh::fuzz
